/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_codrive.h
 * @brief A CANopen CiA 402 drive (one axis) on the CAN HAL: what `evenfeed sim-drive can`
 * runs, and what a real drive's firmware can run.
 *
 * CiA 301 slave: boot-up message, NMT slave (pre-operational / operational / stopped, reset
 * communication and node), heartbeat producer (0x1017), SDO server with expedited and
 * segmented transfers over the object dictionary of docs/can.md, PDOs whose communication
 * and mapping parameters the master configures over SDO (disable, remap, re-enable; a
 * mapping the drive cannot honour is refused with an abort naming why), EMCY producer.
 *
 * CiA 402: the power state machine driven by the controlword (0x6040), reported in the
 * statusword (0x6041); modes CSP (8: target position per SYNC) and evenfeed segment mode
 * (-1: segments reassembled from the law/axis record chunks, ef_canopen.h), both executed
 * by the drive model of ef_drive.h (servo with lag and limits, so a following error exists;
 * controlled stops; faults). A fault sends an EMCY and enters FAULT; fault reset (rising edge
 * of controlword bit 7) returns to SWITCH ON DISABLED.
 *
 * Time: motion advances only at SYNC, by the communication cycle period 0x1006 (drive
 * time is SYNC time, see ef_canopen.h). RPDOs of synchronous transmission type (0..240)
 * are latched and applied at the next SYNC; type 254/255 apply on receipt. TPDOs of type 1
 * are sent after every SYNC (after the motion step, so they report the new state).
 * ef_codrive_process() runs the wall-clock duties: boot-up, heartbeat, TX retries, and the
 * SYNC-loss watchdog (0x2003, default ::EF_CODRIVE_SYNC_TIMEOUT_MS): while the drive is in
 * OPERATION ENABLED (or QUICK STOP ACTIVE / FAULT REACTION ACTIVE still moving), NMT
 * OPERATIONAL, with a non-zero cycle period, a SYNC gap of the timeout raises the WATCHDOG
 * fault (EMCY 0x8130, or none if a fault is already being reacted to). The gap is the time
 * the process() calls report after the first call that follows the last SYNC (a SYNC
 * handled between two calls counts as arriving at the second: a caller held back with SYNCs
 * waiting in its receive queue, which it hands over before its next call, never trips it).
 * From then on, until
 * a SYNC comes again, ef_codrive_process() steps the drive model by the wall-clock time it is
 * given: the stop ramps down from where and how fast the axis was at the last SYNC (during
 * the gap itself the axis holds: a SYNC may merely be late), then FAULT. A SYNC takes the
 * stepping back (never both).
 *
 * Storage: all static; the TX queue (ef_txq.h) holds ::EF_CODRIVE_TXQ frames. A full port
 * queue is retried, not dropped; beyond the queue the policy is ::EF_TXQ_DROP_STALE: the
 * oldest heartbeat/TPDO gives way (the next one supersedes it), never an SDO reply or EMCY
 * (the master waits for those); only a queue holding nothing but SDO replies and EMCYs loses
 * the new frame, counted in txq.lost like the others. A frame the port refuses outright
 * stays queued (::EF_TXQ_REFUSED_KEEP).
 *
 * ## CiA 402 power states (::ef_codrive_t::power, ::ef_co_power_t; numbers are CiA 402's)
 *
 *     state               event                                   next
 *     SWITCH ON DISABLED  controlword shutdown (0x06)             READY TO SWITCH ON (2)
 *     READY TO SWITCH ON  switch on (0x07)                        SWITCHED ON (3)
 *     READY TO SWITCH ON  enable operation (0x0F)                 OPERATION ENABLED (3 + 4)
 *     READY TO SWITCH ON  disable voltage / quick stop            SWITCH ON DISABLED (7)
 *     SWITCHED ON         enable operation                        OPERATION ENABLED (4)
 *     SWITCHED ON         shutdown                                READY TO SWITCH ON (6)
 *     SWITCHED ON         disable voltage / quick stop            SWITCH ON DISABLED (10)
 *     OPERATION ENABLED   switch on / shutdown / disable voltage  the same state until the
 *                                                                 controlled stop is at rest,
 *                                                                 then SWITCHED ON (5) /
 *                                                                 READY (8) / DISABLED (9)
 *     OPERATION ENABLED   enable operation during such a stop     stays (the stop cancelled)
 *     OPERATION ENABLED   quick stop                              QUICK STOP ACTIVE (11)
 *     QUICK STOP ACTIVE   at rest (quick stop option 2)           SWITCH ON DISABLED (12)
 *     any                 a fault of the drive model (ef_drive.h) FAULT REACTION ACTIVE (13,
 *                         or the SYNC-loss watchdog               EMCY sent), then FAULT (14)
 *                                                                 at rest
 *     FAULT               fault reset (rising edge of bit 7)      SWITCH ON DISABLED (15)
 *     any                 reset node                              SWITCH ON DISABLED
 *
 * Entering OPERATION ENABLED in segment mode clears the segment queue (sequence numbers
 * start at 0); there, controlword bit 4 (run, a level) starts the queue and clearing it
 * while moving is a quick stop of the drive model (the power state stays).
 *
 * ## SDO server (::ef_codrive_t::sdo_state, ::ef_codrive_sdo_t)
 *
 *     state     request (client)                              next      answer
 *     any       initiate download, expedited, accepted        IDLE      initiate response
 *     any       initiate download, segmented, accepted        DOWNLOAD  initiate response
 *     DOWNLOAD  segment, right toggle and length, c = 0       DOWNLOAD  segment response
 *     DOWNLOAD  segment, right toggle and length, c = 1       IDLE      segment response (after
 *                                                                       the object's write)
 *     any       initiate upload, up to 4 bytes                IDLE      expedited response
 *     any       initiate upload, longer (the device name)     UPLOAD    initiate response, size
 *     UPLOAD    segment request, right toggle, more           UPLOAD    segment
 *     UPLOAD    segment request, right toggle, the last       IDLE      segment with c = 1
 *     any       abort from the client                         IDLE      none
 *     any       anything refused (object, access, length,     IDLE      abort with the reason
 *               toggle, specifier, value)
 *     any       NMT stop, reset communication, reset node     IDLE      none
 *
 * ## Object dictionary
 * One table in ef_codrive.c (docs/can.md lists it): a row per index (or run of PDO indices)
 * and sub-index range, with size, access, and read/write hooks. A read takes the hook's
 * value (or the row's constant); a write is checked for existence, access and length by
 * the table, then the hook checks the value and applies it. TPDOs read their mapped
 * objects through the same rows.
 *
 * Details the profile leaves open, as implemented:
 * - NMT: INITIALISING ignores every frame until the boot-up is sent. PRE-OPERATIONAL: NMT,
 *   SDO, SYNC (motion steps), EMCY, heartbeat; no PDOs. OPERATIONAL: also PDOs. STOPPED: NMT
 *   and heartbeat only. Reset communication restores 0x1005, 0x1006 (0), 0x1017 (0: no
 *   heartbeat until the master sets one) and the PDO parameters, and sends the boot-up at
 *   once; reset node also restores the application objects (mode CSP, SWITCH ON DISABLED,
 *   0x6065 from servo.ferr_lim, 0x2003, counters) and restarts the drive model where the
 *   axis is. A stop the watchdog is stepping goes on through NMT commands other than reset
 *   node. Leaving OPERATIONAL (stop, pre-operational, reset communication) while the axis
 *   moves or stops is an abort connection (CiA 402 0x6007 option 1, fixed here): the
 *   WATCHDOG fault (EMCY 0x8130, sent before the new state) and its reaction on the wall
 *   clock, since the master's PDOs and perhaps its SYNC no longer arrive.
 * - PDO defaults: RPDO1 0x200+node type 1 {0x6040, 0x607A}; TPDO1 0x180+node type 1 {0x6041,
 *   0x6064}; RPDO2 0x300+node, RPDO3 0x400+node (type 255) and TPDO2 0x280+node (type 1)
 *   disabled and empty. Types 0..240 and 254/255 are accepted. A synchronous RPDO keeps
 *   the latest frame received before the SYNC. TPDO type n is sent every n-th SYNC, type 0
 *   at a SYNC when its data changed, 254/255 when its data changed (checked after every
 *   received frame). COB-IDs change only while the PDO is invalid; CiA 301 restricted
 *   identifiers and the SYNC identifier are refused (0x06090030).
 * - Controlword: commands act as levels in the state they find (CiA 402 table; 0x0F in READY
 *   is transitions 3 + 4); with bit 7 set only its rising edge counts (fault reset, in FAULT
 *   only: an edge during FAULT REACTION ACTIVE is not remembered). Leaving OPERATION ENABLED
 *   (disable operation, shutdown, and also disable voltage) is a controlled stop at a_stop:
 *   the statusword shows OPERATION ENABLED until the axis is at rest, then the new state.
 * - EMCY error register (0x1001, EMCY byte 2): bit 0 (generic) with any fault, plus bit 5
 *   (device profile) for a following error, bit 4 (communication) for the watchdog, bit 7
 *   (manufacturer) for underrun, injected and segment faults; 0 after the fault reset. 0x603F
 *   is cleared by the fault reset, 0x2001 keeps the last fault.
 * - Segment mode: a law record waits for the axis record of the same number; the previous
 *   unpaired law record is kept too, so a law record that overtakes the previous segment's
 *   axis record on the bus (lower identifier) still pairs. Records are counted in seg_dropped
 *   when a chunk is missing, on a sequence gap, when the ring is full, and when the drive is
 *   not executing segments (not OPERATION ENABLED in mode -1). A record the codec refuses
 *   (non-finite data) or a segment ef_drive_push() refuses (not continuous) is a SEGMENT
 *   fault while executing segments.
 */
#ifndef EF_CODRIVE_H
#define EF_CODRIVE_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/canopen/ef_txq.h"
#include "evenfeed/drive/ef_drive.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Frames the drive queues while its port is busy. */
#ifndef EF_CODRIVE_TXQ
#define EF_CODRIVE_TXQ 16
#endif
/** Longest segmented SDO download the drive accepts (bytes; none of its objects is longer). */
#ifndef EF_CODRIVE_SDO_BUF
#define EF_CODRIVE_SDO_BUF 32
#endif
/** Target reached window (statusword bit 10, increments): the actual position within this of
 *  the target (CSP) or of the command (segment mode), with the command at rest. */
#ifndef EF_CODRIVE_POS_WINDOW
#define EF_CODRIVE_POS_WINDOW 10
#endif
/** Most ef_drive_process() calls one SYNC steps: 0x1006 is at most this times
 *  EF_DRIVE_MAX_STEPS servo periods (1.024 s at the 1000 us default). */
#define EF_CODRIVE_SYNC_CALLS 16u
/** SYNC loss timeout (0x2003) at power-up and after reset node (ms; 0 = off). */
#define EF_CODRIVE_SYNC_TIMEOUT_MS 500u
/** Largest SYNC loss timeout 0x2003 accepts (ms). */
#define EF_CODRIVE_SYNC_TIMEOUT_MAX_MS 60000u
/** PDOs of each direction (RPDO1..3, TPDO1..2). */
#define EF_CODRIVE_RPDOS 3
#define EF_CODRIVE_TPDOS 2

/** Drive configuration. */
typedef struct {
    uint8_t node;             /**< node id 1..127 */
    ef_servo_cfg_t servo;     /**< servo model (ef_drive.h) */
    uint32_t servo_period_us; /**< servo model step (default 1000); the cycle period must be a
                                   multiple of it */
    uint32_t inc_per_unit;    /**< 0x2000 (default ::EF_CO_INC_PER_UNIT) */
    float home;               /**< position at power-up (program units) */
    uint32_t serial;          /**< 0x1018:4 */
} ef_codrive_cfg_t;

/** @brief Defaults: servo defaults, 1000 us, EF_CO_INC_PER_UNIT, home 0, serial = node
 *  (0x6065 starts at servo.ferr_lim * inc_per_unit; writing it sets the servo's ferr_lim). */
void ef_codrive_cfg_default(ef_codrive_cfg_t *c, uint8_t node);

/** One PDO's parameters (private). */
typedef struct {
    uint32_t cobid; /**< with EF_CO_PDO_INVALID when disabled */
    uint8_t type;   /**< transmission type */
    uint8_t count;  /**< mapped entries */
    uint8_t pad[2];
    uint32_t map[8];    /**< EF_CO_MAP entries */
    uint8_t latched[8]; /**< RPDO: data waiting for the next SYNC */
    uint8_t has_latched;
    uint8_t pad2[3];
} ef_codrive_pdo_t;

/** SDO server states (see the table above). */
typedef enum {
    EF_CODRIVE_SDO_IDLE = 0, /**< no transfer under way */
    EF_CODRIVE_SDO_DOWNLOAD, /**< segmented download: segments expected */
    EF_CODRIVE_SDO_UPLOAD,   /**< segmented upload: segment requests expected */
} ef_codrive_sdo_t;

/** A decoded law record waiting for its axis record (private). */
typedef struct {
    ef_timelaw_t law;
    float length, v_exit, duration;
    uint16_t flags, seq16;
    uint8_t valid, pad[3];
} ef_codrive_law_t;

/** Drive state (public for static allocation; read the documented fields only). */
typedef struct {
    ef_codrive_cfg_t cfg;
    ef_can_port_t port;
    ef_drive_t drv;       /**< the drive model (x is this drive's axis) */
    uint8_t nmt;          /**< EF_CO_NMT_* state */
    uint8_t power;        /**< ::ef_co_power_t */
    int8_t mode;          /**< 0x6060 */
    int8_t mode_display;  /**< 0x6061 */
    uint16_t controlword; /**< last applied */
    uint16_t statusword;
    uint16_t error_code;      /**< 0x603F */
    uint16_t hb_ms;           /**< 0x1017 (0 after reset communication: off) */
    uint32_t cycle_us;        /**< 0x1006 (0 after reset communication: SYNC steps no motion) */
    uint32_t ferr_window;     /**< 0x6065 (increments) */
    uint32_t sync_count;      /**< SYNCs processed (pre-operational or operational) */
    uint32_t hb_acc_us;       /**< time since the last heartbeat */
    uint8_t booted;           /**< boot-up message sent */
    uint8_t hb_off;           /**< heartbeat suppressed (fault injection) */
    uint16_t sync_timeout_ms; /**< 0x2003 (0: watchdog off) */
    uint32_t sync_gap_us;     /**< time since the last SYNC while the watchdog watches */
    uint8_t sync_lost;        /**< the watchdog tripped: process() steps the stop until at rest
                                   or until a SYNC steps again */
    uint8_t sync_seen;        /**< a SYNC came since the last process() call */
    uint8_t pad[2];
    ef_codrive_pdo_t rpdo[EF_CODRIVE_RPDOS];
    ef_codrive_pdo_t tpdo[EF_CODRIVE_TPDOS];
    /* SDO server: one transfer at a time. */
    uint8_t sdo_state; /**< ::ef_codrive_sdo_t */
    uint8_t sdo_toggle;
    uint16_t sdo_index;
    uint8_t sdo_sub, pad3[3];
    uint32_t sdo_len, sdo_pos;
    uint8_t sdo_buf[EF_CODRIVE_SDO_BUF];
    /* Segment mode. */
    ef_co_asm_t asm_law, asm_axis;
    ef_move_t pend; /**< segment being assembled */
    uint8_t have_law, have_axis;
    uint16_t law_seq16, axis_seq16;
    uint32_t seg_dropped, seg_dups;
    /* TX queue: ::EF_TXQ_DROP_STALE, refused frames kept (ef_txq.h says why). */
    ef_txq_t txq;                           /**< count, sent, again, lost: read only */
    ef_can_frame_t txq_buf[EF_CODRIVE_TXQ]; /**< private: its storage */
    uint8_t txq_stale[EF_CODRIVE_TXQ];      /**< private: the queued frame is a heartbeat or TPDO */
    uint32_t rx_ignored; /**< frames not for this drive or malformed (counted, harmless) */
    /* Private (ef_codrive.c). */
    uint8_t power_next;                  /**< OPERATION ENABLED left by a stop: the state it ends in
                                              (EF_CO_PS_OP_ENABLED: none pending) */
    uint8_t fault_sent;                  /**< the EMCY of the present fault went out */
    uint8_t last_fault;                  /**< 0x2001 */
    uint8_t error_reg;                   /**< 0x1001 */
    uint8_t bus_err;                     /**< the port said EF_ERR_BUS since the last process() */
    uint8_t tpdo_cnt[EF_CODRIVE_TPDOS];  /**< SYNCs since the TPDO was last sent */
    uint8_t tpdo_sent[EF_CODRIVE_TPDOS]; /**< tpdo_last holds what was last sent */
    uint8_t pad4[3];
    uint8_t tpdo_last[EF_CODRIVE_TPDOS][8];
    uint32_t sync_cobid;       /**< 0x1005 */
    int32_t target_inc;        /**< 0x607A */
    uint32_t faults;           /**< faults reported (EMCY sent) since init */
    ef_codrive_law_t law_prev; /**< the law record before the pending one, still unpaired */
} ef_codrive_t;

/**
 * @brief Power up: NMT INITIALISING; the boot-up message goes out on the first
 * ef_codrive_process() call, then PRE-OPERATIONAL; power state SWITCH ON DISABLED.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, no port send, node not 1..127, servo parameters refused by
 *                    ef_drive_init(), period 0, inc_per_unit 0, home not finite
 */
int ef_codrive_init(ef_codrive_t *d, const ef_codrive_cfg_t *c, const ef_can_port_t *port);

/**
 * @brief Handle one received frame (any identifier: what is not for this drive is ignored
 * and counted in rx_ignored; so is a malformed frame, e.g. a wrong length).
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_DRIVE this frame raised a drive fault: its SYNC step, or a segment refused on
 *                      receipt (EMCY sent)
 */
int ef_codrive_rx(ef_codrive_t *d, const ef_can_frame_t *f);

/**
 * @brief Wall-clock duties: boot-up, heartbeat, retry of queued frames, the SYNC-loss
 * watchdog and the stop it steps on the wall clock (dt_us of it per call, at most
 * ::EF_CODRIVE_SYNC_CALLS times (EF_DRIVE_MAX_STEPS - 1) servo periods).
 * @param next_us out (may be NULL): when to call again at the latest (the next servo period
 *                while the watchdog's stop runs, at the latest the watchdog deadline)
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_BUS   the port reported bus-off / interface down (takes precedence)
 * @retval EF_ERR_DRIVE this call raised a drive fault: the watchdog (EMCY sent)
 */
int ef_codrive_process(ef_codrive_t *d, uint32_t dt_us, uint32_t *next_us);

/**
 * @brief Inject a fault (::ef_drive_fault_t, e.g. EF_DRV_FAULT_INJECTED): EMCY, controlled
 * stop, FAULT.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL or bad code
 */
int ef_codrive_fault(ef_codrive_t *d, int code);

/** @brief Fault injection: stop (off != 0) or resume the heartbeat. */
void ef_codrive_heartbeat_off(ef_codrive_t *d, int off);

/** @brief Actual position (program units). */
float ef_codrive_position(const ef_codrive_t *d);

#ifdef __cplusplus
}
#endif

#endif /* EF_CODRIVE_H */
