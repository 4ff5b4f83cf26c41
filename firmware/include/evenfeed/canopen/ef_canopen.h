/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canopen.h
 * @brief CANopen (CiA 301) and CiA 402 definitions shared by evenfeed's master
 * (ef_comaster.h) and drive (ef_codrive.h), and the codec of evenfeed's segment mode.
 *
 * docs/can.md is the specification; this header is the same in code. Summary:
 *
 * - Predefined connection set, 11-bit identifiers, node ids 1..127.
 * - The drive's object dictionary: the CiA 301 communication objects, the CiA 402 objects
 *   of cyclic synchronous position mode (CSP, mode 8), and evenfeed's segment-mode objects
 *   at 0x2100..0x2102 (mode -1, manufacturer specific).
 * - Positions on the CiA 402 objects (0x607A, 0x6064, 0x60F4) are signed 32-bit increments,
 *   ::EF_CO_INC_PER_UNIT per program unit unless 0x2000 says otherwise. Segment data carry
 *   float32 program units.
 * - Drive time is SYNC time: a drive advances its motion by the communication cycle period
 *   (0x1006) at every SYNC, so all drives on a bus move in lockstep with the SYNC producer.
 *
 * ## Segment mode on the bus
 * A segment (ef_move_t) is sent as two records: the **law record** (everything the axes share:
 * sequence number, flags, arc length, exit speed, time law) once, on a PDO every drive
 * receives (COB-ID ::EF_CO_LAW_COBID, RPDO3, object 0x2101), and one **axis record** per drive
 * (its axis's control points, RPDO2 at 0x300 + node, object 0x2100). A record is cut into
 * chunks of 7 bytes; each chunk travels in an 8-byte PDO whose first byte is
 * `(seq & 0x7) << 5 | chunk index` (up to 32 chunks; a full law record takes 22). Records,
 * little-endian:
 *
 *     law:  u16 seq, u8 flags (bit 0: EF_MOVE_STOP_END), u8 phase mask (bit k: phase k sent,
 *           k < 7), f32 length, f32 v_exit, then per sent phase: f32 dt, f32 c[4]
 *                                                                          (12 + 20 n bytes)
 *     axis: u16 seq, u8 degree (1, 3, 5), u8 0, f32 b[0..degree]            (8 + 4 degree bytes)
 *
 * A phase is sent unless its dt and all its coefficients are 0 (a phase not sent decodes as
 * zeros), so the codec is lossless. Sequence numbers are 16-bit on the wire; the drive
 * extends them against the one it expects. Flow control is in TPDO1 (next expected
 * sequence number, low 8 bits, and free ring places); a lost chunk drops its record, the drive
 * keeps expecting that sequence number, and the master sends again from there (go-back-N).
 */
#ifndef EF_CANOPEN_H
#define EF_CANOPEN_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/* --- Identifiers (function code + node id) --------------------------------------------- */
#define EF_CO_COB_NMT       0x000u /**< NMT command: [command, node (0 = all)] */
#define EF_CO_COB_SYNC      0x080u /**< SYNC, no data */
#define EF_CO_COB_EMCY      0x080u /**< + node: emergency */
#define EF_CO_COB_TPDO1     0x180u /**< + node */
#define EF_CO_COB_RPDO1     0x200u /**< + node */
#define EF_CO_COB_TPDO2     0x280u /**< + node */
#define EF_CO_COB_RPDO2     0x300u /**< + node */
#define EF_CO_COB_RPDO3     0x400u /**< + node (default; segment mode moves RPDO3) */
#define EF_CO_COB_SDO_TX    0x580u /**< + node: server (drive) to client (master) */
#define EF_CO_COB_SDO_RX    0x600u /**< + node: client to server */
#define EF_CO_COB_HEARTBEAT 0x700u /**< + node: NMT error control (boot-up, heartbeat) */
/** COB-ID every drive's RPDO3 is given in segment mode: the shared law records. It is the
 *  TPDO2 identifier of node 0, which does not exist, so it collides with no node. */
#define EF_CO_LAW_COBID 0x280u
/** Bit 31 of a PDO COB-ID (0x14xx/0x18xx sub 1): the PDO is not valid (disabled). */
#define EF_CO_PDO_INVALID 0x80000000u

/* --- NMT --------------------------------------------------------------------------------- */
#define EF_CO_NMT_START      0x01u /**< to Operational */
#define EF_CO_NMT_STOP       0x02u /**< to Stopped */
#define EF_CO_NMT_PREOP      0x80u /**< to Pre-operational */
#define EF_CO_NMT_RESET_NODE 0x81u /**< reset application */
#define EF_CO_NMT_RESET_COMM 0x82u /**< reset communication (boot-up follows) */
/** NMT states as sent in heartbeats (byte 0). */
#define EF_CO_NMT_BOOTUP         0x00u
#define EF_CO_NMT_STOPPED        0x04u
#define EF_CO_NMT_OPERATIONAL    0x05u
#define EF_CO_NMT_PREOPERATIONAL 0x7Fu

/* --- SDO (expedited and segmented; no block transfer) ------------------------------------ */
#define EF_CO_SDO_ABORT 0x80u /**< command byte of an abort (both directions) */
/** SDO abort codes used by evenfeed (CiA 301 table 22). */
#define EF_CO_ABORT_TOGGLE    0x05030000u /**< toggle bit not alternated */
#define EF_CO_ABORT_TIMEOUT   0x05040000u /**< SDO protocol timed out */
#define EF_CO_ABORT_CS        0x05040001u /**< command specifier not valid or unknown */
#define EF_CO_ABORT_ACCESS    0x06010000u /**< unsupported access to an object */
#define EF_CO_ABORT_WRITEONLY 0x06010001u /**< attempt to read a write-only object */
#define EF_CO_ABORT_READONLY  0x06010002u /**< attempt to write a read-only object */
#define EF_CO_ABORT_NO_OBJECT 0x06020000u /**< object does not exist */
#define EF_CO_ABORT_NO_MAP    0x06040041u /**< object cannot be mapped to the PDO */
#define EF_CO_ABORT_MAP_LEN   0x06040042u /**< mapped objects exceed the PDO length */
#define EF_CO_ABORT_PARAM     0x06040043u /**< general parameter incompatibility */
#define EF_CO_ABORT_LEN       0x06070010u /**< data type does not match, length wrong */
#define EF_CO_ABORT_NO_SUB    0x06090011u /**< sub-index does not exist */
#define EF_CO_ABORT_RANGE     0x06090030u /**< value range of parameter exceeded */
#define EF_CO_ABORT_GENERAL   0x08000000u /**< general error */
#define EF_CO_ABORT_STATE     0x08000022u /**< not possible in the present device state */
/** @brief Text of an SDO abort code ("unknown abort code" otherwise). Never NULL. */
const char *ef_co_abort_str(uint32_t code);

/* --- Object dictionary (the drive's; docs/can.md lists access and types) ----------------- */
#define EF_CO_OBJ_DEVICE_TYPE  0x1000u /**< u32 ro: 0x00020192 (CiA 402 servo drive) */
#define EF_CO_OBJ_ERROR_REG    0x1001u /**< u8 ro */
#define EF_CO_OBJ_SYNC_COBID   0x1005u /**< u32 rw: 0x80 */
#define EF_CO_OBJ_CYCLE        0x1006u /**< u32 rw: communication cycle period (us) */
#define EF_CO_OBJ_DEVICE_NAME  0x1008u /**< visible string ro (segmented upload) */
#define EF_CO_OBJ_EMCY_COBID   0x1014u /**< u32 ro: 0x80 + node */
#define EF_CO_OBJ_HB_PRODUCER  0x1017u /**< u16 rw: heartbeat period (ms), 0 = off */
#define EF_CO_OBJ_IDENTITY     0x1018u /**< record: 1 vendor, 2 product, 3 revision, 4 serial */
#define EF_CO_OBJ_RPDO_COMM    0x1400u /**< + k: sub 1 COB-ID u32, sub 2 transmission type u8 */
#define EF_CO_OBJ_RPDO_MAP     0x1600u /**< + k: sub 0 count u8, sub 1..8 entries u32 */
#define EF_CO_OBJ_TPDO_COMM    0x1800u /**< + k: sub 1 COB-ID u32, sub 2 transmission type u8 */
#define EF_CO_OBJ_TPDO_MAP     0x1A00u /**< + k */
#define EF_CO_OBJ_INC_PER_UNIT 0x2000u /**< u32 ro: position increments per program unit */
#define EF_CO_OBJ_DRIVE_FAULT  0x2001u /**< u8 ro: ::ef_drive_fault_t of the last fault */
/** u16 rw: SYNC loss timeout (ms, 0 = off, default 500): a drive enabled (or still stopping)
 *  in OPERATIONAL with a cycle period that sees no SYNC this long raises the WATCHDOG fault
 *  (EMCY 0x8130) and stops under control on its own clock. */
#define EF_CO_OBJ_SYNC_TIMEOUT 0x2003u
#define EF_CO_OBJ_SEG_AXIS     0x2100u /**< u64 wo, RPDO-mappable: axis record chunk */
#define EF_CO_OBJ_SEG_LAW      0x2101u /**< u64 wo, RPDO-mappable: law record chunk */
#define EF_CO_OBJ_SEG_STATUS   0x2102u /**< record ro: see EF_CO_SEGST_* */
#define EF_CO_SEGST_NEXT8      1u      /**< u8, TPDO-mappable: next expected seq, low 8 bits */
#define EF_CO_SEGST_FREE       2u      /**< u8, TPDO-mappable: free ring places */
#define EF_CO_SEGST_NEXT       3u      /**< u32: next expected sequence number */
#define EF_CO_SEGST_DONE       4u      /**< u32: segments completed since the queue was cleared */
#define EF_CO_SEGST_DROPPED    5u /**< u32: records dropped (a chunk missing or out of order) */
#define EF_CO_SEGST_DUPS       6u /**< u32: records already accepted, ignored */
#define EF_CO_OBJ_ERROR_CODE   0x603Fu /**< u16 ro: last EMCY error code */
#define EF_CO_OBJ_CONTROLWORD  0x6040u /**< u16 rw, RPDO-mappable */
#define EF_CO_OBJ_STATUSWORD   0x6041u /**< u16 ro, TPDO-mappable */
#define EF_CO_OBJ_MODE         0x6060u /**< i8 rw: modes of operation */
#define EF_CO_OBJ_MODE_DISPLAY 0x6061u /**< i8 ro */
#define EF_CO_OBJ_POS_ACTUAL   0x6064u /**< i32 ro, TPDO-mappable (increments) */
#define EF_CO_OBJ_FERR_WINDOW  0x6065u /**< u32 rw: following error window (increments) */
#define EF_CO_OBJ_TARGET_POS   0x607Au /**< i32 rw, RPDO-mappable (increments) */
#define EF_CO_OBJ_FERR_ACTUAL  0x60F4u /**< i32 ro, TPDO-mappable (increments) */
#define EF_CO_OBJ_SUPPORTED                                                                        \
    0x6502u /**< u32 ro: supported drive modes (bit 7 CSP, bit 16                                  \
                 evenfeed segment mode) */
/** Device type of an evenfeed drive (0x1000). */
#define EF_CO_DEVICE_TYPE_402 0x00020192u
/** Increments per program unit unless the drive's 0x2000 differs (0.1 um per mm). */
#define EF_CO_INC_PER_UNIT 10000u
/** A PDO mapping entry (0x16xx / 0x1Axx sub 1..8). */
#define EF_CO_MAP(index, sub, bits) (((uint32_t)(index) << 16) | ((uint32_t)(sub) << 8) | (bits))

/* --- CiA 402 --------------------------------------------------------------------------- */
#define EF_CO_MODE_CSP     8    /**< cyclic synchronous position */
#define EF_CO_MODE_SEGMENT (-1) /**< evenfeed segment mode (manufacturer specific) */
/** Controlword commands (bit 7 fault reset acts on its rising edge). */
#define EF_CO_CW_SHUTDOWN        0x0006u
#define EF_CO_CW_SWITCH_ON       0x0007u
#define EF_CO_CW_ENABLE_OP       0x000Fu
#define EF_CO_CW_DISABLE_VOLTAGE 0x0000u
#define EF_CO_CW_QUICK_STOP      0x0002u
#define EF_CO_CW_FAULT_RESET     0x0080u
/** Controlword bit 4 in segment mode: execute the queue (level; all drives see it at the same
 *  SYNC, so they start together). Clearing it while moving is a quick stop. */
#define EF_CO_CW_SEG_RUN 0x0010u
/** Controlword bit 8, halt (CiA 402), in segment mode: feed hold. The drive decelerates
 *  along the path to rest and stands there, still executing (ef_drive.h's feed hold);
 *  clearing it resumes exactly there. A level; RPDO1 is applied at SYNC, so every drive
 *  begins its ramp in the same period. CSP ignores it (the master's targets are the path). */
#define EF_CO_CW_HALT 0x0100u
/** Statusword bits. */
#define EF_CO_SW_FAULT          0x0008u
#define EF_CO_SW_WARNING        0x0080u
#define EF_CO_SW_REMOTE         0x0200u
#define EF_CO_SW_TARGET_REACHED 0x0400u /**< at rest, nothing left to execute */
#define EF_CO_SW_FOLLOWING                                                                         \
    0x1000u                   /**< bit 12: CSP: following the target;                              \
                                   segment mode: executing (queue running) */
#define EF_CO_SW_FERR 0x2000u /**< bit 13: following error above the window */
/** Statusword bit 14 (manufacturer specific), segment mode: feed hold complete (halt
 *  requested and the drive stands on the path). */
#define EF_CO_SW_HELD 0x4000u
/** Power states decoded from the statusword. */
typedef enum {
    EF_CO_PS_NOT_READY = 0, /**< not ready to switch on */
    EF_CO_PS_SWITCH_ON_DISABLED = 1,
    EF_CO_PS_READY = 2, /**< ready to switch on */
    EF_CO_PS_SWITCHED_ON = 3,
    EF_CO_PS_OP_ENABLED = 4, /**< operation enabled */
    EF_CO_PS_QUICK_STOP = 5, /**< quick stop active */
    EF_CO_PS_FAULT_REACTION = 6,
    EF_CO_PS_FAULT = 7,
} ef_co_power_t;
/** @brief Power state of a statusword (CiA 402 table: masks 0x4F / 0x6F). */
ef_co_power_t ef_co_power_state(uint16_t statusword);
/** @brief Name of a power state ("?" otherwise). */
const char *ef_co_power_str(int state);

/* --- EMCY ------------------------------------------------------------------------------- */
/** Payload: u16 error code, u8 error register (0x1001), u8 ::ef_drive_fault_t, u32 the drive's
 *  SYNC count at the fault. Code 0 (error reset) is sent when a fault is reset. */
#define EF_CO_EMCY_NONE      0x0000u
#define EF_CO_EMCY_FOLLOWING 0x8611u /**< CiA 402: following error */
#define EF_CO_EMCY_HEARTBEAT 0x8130u /**< life guard / heartbeat error (drive watchdog) */
#define EF_CO_EMCY_UNDERRUN  0xFF01u /**< segment queue ran dry while moving */
#define EF_CO_EMCY_INJECTED  0xFF04u /**< fault injected (tests, external input) */
#define EF_CO_EMCY_SEGMENT   0xFF05u /**< a segment was refused (bad data, not continuous) */
#define EF_CO_EMCY_STO       0xFF06u /**< safe torque off: the enable input dropped */
/** @brief EMCY code of an ::ef_drive_fault_t. */
uint16_t ef_co_emcy_of_fault(int drive_fault);
/** @brief Text of an EMCY error code. Never NULL. */
const char *ef_co_emcy_str(uint16_t code);

/* --- Little-endian access ---------------------------------------------------------------- */
static inline uint16_t ef_co_get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}
static inline uint32_t ef_co_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static inline void ef_co_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void ef_co_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* --- Positions --------------------------------------------------------------------------- */
/**
 * @brief Program units to increments, rounded to nearest.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL out or inc_per_unit 0
 * @retval EF_ERR_NONFINITE x not finite, or the result outside int32
 */
int ef_co_pos_to_inc(float x, uint32_t inc_per_unit, int32_t *out);
/** @brief Increments to program units (inc_per_unit 0 counts as 1). */
float ef_co_inc_to_pos(int32_t inc, uint32_t inc_per_unit);

/* --- Segment-mode codec -------------------------------------------------------------------- */
/** Chunk header byte: the low bits carry the chunk index, the high bits the record's
 *  sequence number's low bits. */
#define EF_CO_CHUNK_INDEX_BITS 5u
#define EF_CO_CHUNK_INDEX_MASK 0x1Fu
#define EF_CO_CHUNK_SEQ_MASK   0x07u
/** Payload bytes per chunk. */
#define EF_CO_CHUNK_BYTES 7u
/** Bytes of one time-law phase in a law record: its duration and its coefficients. */
#define EF_CO_PHASE_BYTES (4u + 4u * EF_TIMELAW_COEFFS)
/** Largest record (a law record with every phase used: 12 + 7 x 20 bytes). */
#define EF_CO_REC_MAX (12u + EF_CO_PHASE_BYTES * EF_TIMELAW_PHASES)
/** Most chunks of one record: ceil(EF_CO_REC_MAX / 7). */
#define EF_CO_CHUNKS_MAX ((EF_CO_REC_MAX + EF_CO_CHUNK_BYTES - 1u) / EF_CO_CHUNK_BYTES)

/**
 * @brief Encode a move's law record (seq's low 16 bits, flags, length, v_exit, law).
 * @param len out: record bytes (12 + EF_CO_PHASE_BYTES n, n the phases used)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_co_law_encode(const ef_move_t *m, uint8_t rec[EF_CO_REC_MAX], uint32_t *len);
/**
 * @brief Encode a move's axis record for axis 0 (x), 1 (y), 2 (z) or an auxiliary axis
 * 3 + k (A B C U V W: the move's ab[k]); a drive decodes any of them alike (its one axis).
 * @param len out: record bytes (8 + 4 degree)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, axis not 0..EF_AXES-1, degree not 1/3/5
 */
int ef_co_axis_encode(const ef_move_t *m, int axis, uint8_t rec[EF_CO_REC_MAX], uint32_t *len);
/** @brief Chunks of a record of len bytes: ceil(len / 7). */
uint32_t ef_co_chunk_count(uint32_t len);
/** @brief The 8 data bytes of chunk k (k < ef_co_chunk_count(len)) of a record (zero padded). */
void ef_co_chunk(const uint8_t *rec, uint32_t len, uint32_t k, uint8_t data[8]);

/** Reassembly of one record stream (one per stream: law, axis). */
typedef struct {
    uint8_t rec[EF_CO_REC_MAX];
    uint32_t len;     /**< record length (known after chunk 0), 0 while idle */
    uint32_t next;    /**< chunk index expected next */
    uint32_t rec_len; /**< after ef_co_asm_feed() returned EF_OK: the record's length */
    uint8_t seq4;     /**< the record's sequence bits (EF_CO_CHUNK_SEQ_MASK) */
    uint8_t law;      /**< this stream carries law records (else axis records) */
} ef_co_asm_t;
/** @brief Idle reassembly of law (law != 0) or axis records. */
void ef_co_asm_init(ef_co_asm_t *a, int law);
/**
 * @brief Feed one chunk.
 * A chunk with index 0 always starts a new record (a partial one is dropped). A chunk that
 * is not the expected next one of the record under way (index or sequence bits) drops the
 * record, and chunks are then ignored until the next index 0.
 * @retval EF_OK     the record is complete in a->rec[0..a->rec_len-1] (the stream is idle again)
 * @retval EF_ERR_AGAIN more chunks needed (or an ignored chunk while idle)
 * @retval EF_ERR_SEQ a record under way was dropped (a chunk missing or out of order)
 * @retval EF_ERR_PROTO chunk 0 announces an impossible record (degree not 1/3/5, phase mask
 *                      above 7): dropped
 * @retval EF_ERR_ARG NULL
 */
int ef_co_asm_feed(ef_co_asm_t *a, const uint8_t data[8]);
/**
 * @brief Decode a law record into m: seq (low 16 bits), flags, length, v_exit, law, duration
 * (the sum of the phase durations). Other fields are untouched.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or len not the length its phase mask implies
 * @retval EF_ERR_NONFINITE a non-finite number
 */
int ef_co_law_decode(const uint8_t *rec, uint32_t len, ef_move_t *m);
/**
 * @brief Decode an axis record: degree and b[0..degree].x (y, z set to 0), seq in *seq16.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, degree not 1/3/5, or len not 8 + 4 degree
 * @retval EF_ERR_NONFINITE a non-finite control point
 */
int ef_co_axis_decode(const uint8_t *rec, uint32_t len, ef_move_t *m, uint16_t *seq16);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANOPEN_H */
