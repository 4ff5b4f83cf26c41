/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_modbus.h
 * @brief evenfeed's Modbus register map (docs/modbus.md), the segment slot codec and the
 * drive-side register device.
 *
 * Transport-free: a drive's firmware (or the simulated drive, host/) receives Modbus
 * requests with whatever stack it has and hands the register range of each to
 * ef_mbdev_read() / ef_mbdev_write(), which validate, act on the drive (ef_drive.h) and
 * say which Modbus exception to answer with. The master side encodes slots with
 * ef_mb_slot_encode(), which computes the slot's CRC: there is no other way to make one.
 *
 * All registers are holding registers (FC3 read, FC6/FC16 write), addresses as on the
 * wire (0-based). 32-bit values take two registers, high word first; floats are IEEE-754
 * binary32 in that order ("ABCD"); within a register, Modbus sends the high byte first.
 */
#ifndef EF_MODBUS_H
#define EF_MODBUS_H

#include <stdint.h>
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** @name Identification (read-only) */
/**@{*/
#define EF_MB_REG_MAGIC      0x0000 /**< 0x4546 ("EF") */
#define EF_MB_REG_VERSION    0x0001 /**< register map version, ::EF_MB_MAP_VERSION */
#define EF_MB_REG_AXES       0x0002 /**< axes per slot: 3 (x, y, z) or 1 (a single-axis drive) */
#define EF_MB_REG_SLOTS      0x0003 /**< slots in the ring, ::EF_DRIVE_SLOTS */
#define EF_MB_REG_SLOT_WORDS 0x0004 /**< registers per slot, ::EF_MB_SLOT_WORDS */
#define EF_MB_REG_SESSION                                                                          \
    0x0005                         /**< nonzero number chosen at power-up: a change means          \
                                        the drive restarted */
#define EF_MB_REG_PERIOD_US 0x0006 /**< u32: servo period (us) */
#define EF_MB_MAGIC         0x4546u
#define EF_MB_MAP_VERSION   1u
/**@}*/

/** @name Control (read/write) */
/**@{*/
#define EF_MB_REG_CONTROL     0x0010 /**< command word, EF_MB_CTL_* bits; acted on at each write */
#define EF_MB_REG_MODE        0x0011 /**< ::EF_MB_MODE_SEGMENT or ::EF_MB_MODE_DIRECT */
#define EF_MB_REG_WATCHDOG    0x0012 /**< ms without a request that faults a RUNNING drive; 0 off */
#define EF_MB_CTL_ENABLE      0x0001u /**< level: 1 enable, 0 disable (stops first) */
#define EF_MB_CTL_START       0x0002u /**< start executing the ring */
#define EF_MB_CTL_QUICK_STOP  0x0004u /**< controlled stop, ring flushed */
#define EF_MB_CTL_FAULT_RESET 0x0008u /**< FAULT -> DISABLED */
#define EF_MB_CTL_CLEAR       0x0010u /**< empty the ring, sequence numbers from 0 */
/** Level, segment mode: feed hold. The drive decelerates along the path and stands there,
 *  still RUNNING; a write without it resumes exactly there (ef_drive.h's feed hold). Refused
 *  (illegal value) in direct mode, where the master's targets are the path. */
#define EF_MB_CTL_HOLD     0x0020u
#define EF_MB_MODE_SEGMENT 1u
#define EF_MB_MODE_DIRECT  2u
/**@}*/

/** @name Status (read-only) */
/**@{*/
#define EF_MB_REG_STATUS     0x0020  /**< EF_MB_ST_* bits */
#define EF_MB_REG_STATE      0x0021  /**< ::ef_drive_state_t */
#define EF_MB_REG_FAULT      0x0022  /**< ::ef_drive_fault_t */
#define EF_MB_REG_FREE       0x0023  /**< free slots */
#define EF_MB_REG_HEAD       0x0024  /**< slot the next segment goes to (next_seq % slots) */
#define EF_MB_REG_TAIL       0x0025  /**< slot executing, or next to execute */
#define EF_MB_REG_NEXT_SEQ   0x0026  /**< u32: sequence number expected next */
#define EF_MB_REG_DONE_SEQ   0x0028  /**< u32: last segment executed; 0xFFFFFFFF: none yet */
#define EF_MB_REG_EXEC_SEQ   0x002A  /**< u32: segment executing (valid with ST_MOVING) */
#define EF_MB_REG_TIME_MS    0x002C  /**< u32: ms executed since the clear */
#define EF_MB_REG_ACT        0x002E  /**< 3 floats: actual position x, y, z */
#define EF_MB_REG_CMD        0x0034  /**< 3 floats: commanded position x, y, z */
#define EF_MB_REG_FERR_MAX   0x003A  /**< float: largest following error since the clear */
#define EF_MB_REG_DONE_COUNT 0x003C  /**< u32: segments executed since the clear */
#define EF_MB_REG_REJECTED   0x003E  /**< u16: writes answered with an exception (wraps) */
#define EF_MB_REG_DUPLICATES 0x003F  /**< u16: slot writes acknowledged as duplicates (wraps) */
#define EF_MB_ST_ENABLED     0x0001u /**< ENABLED, RUNNING or STOPPING */
#define EF_MB_ST_RUNNING     0x0002u
#define EF_MB_ST_MOVING      0x0004u /**< executing a segment (or direct profile moving) */
#define EF_MB_ST_STOPPING    0x0008u
#define EF_MB_ST_FAULT       0x0010u
#define EF_MB_ST_DIRECT      0x0020u
#define EF_MB_ST_HELD        0x0040u /**< feed hold complete: standing on the path */
#define EF_MB_DONE_NONE      0xFFFFFFFFu
/**@}*/

/** @name Direct target (read/write; written as one block of 6 registers) */
/**@{*/
#define EF_MB_REG_TARGET   0x0040 /**< 3 floats: target position x, y, z */
#define EF_MB_TARGET_WORDS 6
/**@}*/

/** @name Segment ring: slot k at EF_MB_REG_SLOT0 + k * EF_MB_SLOT_WORDS, written whole */
/**@{*/
#define EF_MB_REG_SLOT0 0x0100
#define EF_MB_AXES      3 /**< axes of the X Y Z drive's slot (register 0x0002 reads 3) */
/* Word offsets inside a slot. */
#define EF_MB_SLOT_SEQ 0 /**< u32 sequence number; the slot index is seq % slots */
#define EF_MB_SLOT_FORMAT                                                                          \
    2                            /**< low byte: degree (1, 3, 5); high byte: flags, bit 0 =        \
                                      ends at rest (exact stop) */
#define EF_MB_SLOT_RESERVED  3   /**< 0 */
#define EF_MB_SLOT_DURATION  4   /**< float: seconds, > 0 */
#define EF_MB_SLOT_LENGTH    6   /**< float: arc length (units) */
#define EF_MB_SLOT_V_EXIT    8   /**< float: speed at the end (units/s) */
#define EF_MB_SLOT_LAW_DT    10  /**< 7 floats: time-law phase durations */
#define EF_MB_SLOT_LAW_C     24  /**< 28 floats: time-law coefficients, phase by phase */
#define EF_MB_SLOT_POINTS    80  /**< 18 floats: b[0..5] as x, y, z each (unused points 0) */
#define EF_MB_SLOT_CRC       116 /**< CRC-16/MODBUS of words 0..115 sent high byte first */
#define EF_MB_SLOT_WORDS     117 /**< one Write Multiple Registers request (at most 123) */
#define EF_MB_SLOT_FLAG_STOP 0x01u
/**@}*/

/** @name The single-axis drive's slot (register 0x0002 reads 1)
 * Words 0..79 as the X Y Z slot (sequence, format, duration, the X Y Z arc length, v_exit,
 * the time law), then the axis's control values b[0..5] as one float each, then the CRC. */
/**@{*/
#define EF_MB_AXES1       1u /**< axes of the single-axis drive's slot */
#define EF_MB_SLOT1_CRC   92 /**< CRC-16/MODBUS of words 0..91 */
#define EF_MB_SLOT1_WORDS 93 /**< registers per slot of a single-axis drive */
/**@}*/

/** Registers in the X Y Z drive's map (reads at or above this are ILLEGAL DATA ADDRESS); the
 *  largest map of any drive (a single-axis drive's ends at ef_mbdev_regs()). */
#define EF_MB_REGS (EF_MB_REG_SLOT0 + EF_DRIVE_SLOTS * EF_MB_SLOT_WORDS)

/** @name Modbus exception codes the device answers with */
/**@{*/
#define EF_MB_EX_NONE             0
#define EF_MB_EX_ILLEGAL_FUNCTION 1
#define EF_MB_EX_ILLEGAL_ADDRESS  2 /**< outside the map, read-only, or a partial slot/block */
#define EF_MB_EX_ILLEGAL_VALUE    3 /**< bad CRC, bad segment data, sequence gap, bad mode */
#define EF_MB_EX_DEVICE_FAILURE   4 /**< refused in the drive's state (fault, disabled...) */
#define EF_MB_EX_BUSY             6 /**< ring full: retry later */
/**@}*/

/**
 * @brief CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF) of n bytes.
 * @return the CRC (0xFFFF for n == 0 or NULL data)
 */
uint16_t ef_crc16_modbus(const uint8_t *data, uint32_t n);

/** @brief The slot CRC: CRC-16/MODBUS of words w[0..n-1], each sent high byte first. */
uint16_t ef_mb_crc_words(const uint16_t *w, uint32_t n);

/**
 * @brief Encode a move into a slot (fields listed in ef_drive.h), CRC included.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, degree not 1/3/5, duration not > 0
 * @retval EF_ERR_NONFINITE a non-finite number in the fields used
 */
int ef_mb_slot_encode(const ef_move_t *m, uint16_t w[EF_MB_SLOT_WORDS]);

/**
 * @brief Registers per slot of a drive carrying axes axes per slot.
 * @return ::EF_MB_SLOT_WORDS for 3, ::EF_MB_SLOT1_WORDS for 1, 0 for any other count
 */
uint32_t ef_mb_slot_words(uint32_t axes);

/**
 * @brief Encode a move into the slot of a drive carrying axes axes (3: b[i].x, y, z; 1:
 * b[i].x only, the single-axis drive's layout), CRC included. axes 3 is ef_mb_slot_encode().
 * @param w ef_mb_slot_words(axes) registers
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, axes not 1 or 3, degree not 1/3/5, duration not > 0
 * @retval EF_ERR_NONFINITE a non-finite number in the fields used
 */
int ef_mb_slot_encode_axes(const ef_move_t *m, uint32_t axes, uint16_t *w);

/**
 * @brief Decode and check the slot of a drive carrying axes axes (1: the control values go
 * to b[i].x, b[i].y = b[i].z = 0). axes 3 is ef_mb_slot_decode().
 * @param w ef_mb_slot_words(axes) registers
 * @retval as ef_mb_slot_decode(); EF_ERR_ARG also for axes not 1 or 3
 */
int ef_mb_slot_decode_axes(const uint16_t *w, uint32_t axes, ef_move_t *m);

/**
 * @brief Decode and check a slot. Fields not carried are zero.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, degree not 1/3/5, flags or reserved word not as
 *                          documented, duration not > 0
 * @retval EF_ERR_CRC       CRC mismatch (checked first)
 * @retval EF_ERR_NONFINITE a non-finite number
 */
int ef_mb_slot_decode(const uint16_t w[EF_MB_SLOT_WORDS], ef_move_t *m);

/** @brief Store a u32 / float into two registers, high word first. */
void ef_mb_put_u32(uint16_t *w, uint32_t v);
void ef_mb_put_f32(uint16_t *w, float v);
/** @brief Read a u32 / float from two registers, high word first. */
uint32_t ef_mb_get_u32(const uint16_t *w);
float ef_mb_get_f32(const uint16_t *w);

/** The drive-side register device (public for static allocation; treat as private). */
typedef struct {
    ef_drive_t drv;
    uint16_t axes;       /**< axes per slot: 3 (x, y, z) or 1 (the axis in x; y = z = 0) */
    uint16_t slot_words; /**< ef_mb_slot_words(axes) */
    uint16_t session;
    uint16_t control;     /**< last written command word */
    uint16_t mode;        /**< EF_MB_MODE_* */
    uint16_t watchdog_ms; /**< 0: off */
    uint32_t quiet_us;    /**< time since the last request (saturates) */
    uint16_t rejected, duplicates;
    uint16_t target[EF_MB_TARGET_WORDS];
    uint16_t slot[EF_DRIVE_SLOTS][EF_MB_SLOT_WORDS]; /**< last accepted content (read back;
                                                          the first slot_words of each) */
} ef_mbdev_t;

/**
 * @brief Initialise the device and its drive (DISABLED, segment mode, watchdog off).
 * @param session nonzero number that differs between power-ups (e.g. from a timer)
 * @retval EF_OK
 * @retval EF_ERR_ARG session 0, or what ef_drive_init() refuses
 * @retval EF_ERR_NONFINITE home not finite
 */
int ef_mbdev_init(ef_mbdev_t *dev, const ef_servo_cfg_t *cfg, ef_vec3_t home, uint32_t period_us,
                  uint16_t session);

/**
 * @brief ef_mbdev_init() for a drive of axes axes per slot: 3 (the X Y Z drive, what
 * ef_mbdev_init() makes) or 1 (a single-axis drive: its axis is the drive's x; home.y and
 * home.z must be 0, and y and z stay 0).
 * @retval EF_OK
 * @retval EF_ERR_ARG axes not 1 or 3, home.y or home.z not 0 on a single-axis drive, or as
 *                    ef_mbdev_init()
 * @retval EF_ERR_NONFINITE home not finite
 */
int ef_mbdev_init_axes(ef_mbdev_t *dev, const ef_servo_cfg_t *cfg, ef_vec3_t home,
                       uint32_t period_us, uint16_t session, uint32_t axes);

/**
 * @brief Registers in the device's map: ::EF_MB_REG_SLOT0 + slots x its slot size (::EF_MB_REGS
 * for the X Y Z drive).
 * @return the count, 0 for NULL
 */
uint32_t ef_mbdev_regs(const ef_mbdev_t *dev);

/**
 * @brief A read request of n registers from addr (FC3). Fills out[0..n-1] from the live
 * state; registers not in the map's blocks read 0. Counts as traffic for the watchdog.
 * @param exc out: the Modbus exception to answer with, ::EF_MB_EX_NONE on success
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, n == 0 or n > 125, or the range leaves the map (*exc = 2)
 */
int ef_mbdev_read(ef_mbdev_t *dev, uint16_t addr, uint16_t n, uint16_t *out, uint8_t *exc);

/**
 * @brief A write request of n registers at addr (FC6: n == 1, FC16). Validated whole
 * before anything changes; counts as traffic for the watchdog.
 * Writable: the control block (any part of 0x10..0x12), the target block (all 6) and a
 * slot (all of its slot_words, seq % slots == its index). A duplicate slot (sequence
 * number already accepted) is acknowledged without queueing (EF_OK, counted).
 * @param exc out: the Modbus exception to answer with, ::EF_MB_EX_NONE on success
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL, bad range: outside the map, read-only, partial block (*exc 2);
 *                      a bad value: mode, control bits, segment data (*exc 3)
 * @retval EF_ERR_CRC   slot CRC mismatch (*exc 3)
 * @retval EF_ERR_SEQ   slot sequence gap, or seq % slots != slot index (*exc 3)
 * @retval EF_ERR_FULL  ring full (*exc 6)
 * @retval EF_ERR_STATE the drive refuses in its state, e.g. enable in FAULT, a segment
 *                      while DISABLED (*exc 4)
 */
int ef_mbdev_write(ef_mbdev_t *dev, uint16_t addr, uint16_t n, const uint16_t *v, uint8_t *exc);

/**
 * @brief Advance by dt_us: the drive (ef_drive_process()) and the watchdog.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_DRIVE a fault was raised in this call (watchdog or the drive's own)
 */
int ef_mbdev_process(ef_mbdev_t *dev, uint32_t dt_us, uint32_t *next_us);

#ifdef __cplusplus
}
#endif

#endif /* EF_MODBUS_H */
