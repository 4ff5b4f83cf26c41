/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_comaster.h
 * @brief CANopen master for CiA 402 drives on the CAN HAL: bring-up, SYNC, streaming in CSP
 * or evenfeed segment mode, supervision and controlled stops. Freestanding: runs on a
 * controller as well as on the host (over SocketCAN).
 *
 * One object drives up to ::EF_COM_MAX_NODES drives, node k moving axis k (x, y, z, then
 * A B C U V W: ef_move_t::ab in segment mode, the caller's positions in CSP).
 *
 * ## Life cycle (ef_comaster_state())
 *     BOOT:    wait for every node's boot-up message or heartbeat (NMT reset communication
 *              is sent first when cfg.reset_comm); a node silent for boot_timeout_ms is an
 *              ::EF_ERR_HEARTBEAT error naming it.
 *     CONFIG:  per node over SDO (expedited; the device name by segmented upload): check
 *              0x1000 and 0x6502, read 0x2000, set 0x1017 heartbeat, 0x1006 cycle, 0x6065;
 *              PDOs of the mode (docs/can.md): for each, disable (COB-ID bit 31), set the
 *              transmission type, clear the mapping, write the entries, set the count, enable;
 *              each write read back where the drive could silently differ (mapping count);
 *              0x6060 mode, verified in 0x6061.
 *     START:   NMT start all; SYNC production begins (cycle_us); wait for the first TPDO1
 *              of every node (its statusword: the master never commands motion to a drive
 *              whose state it has not read).
 *     ENABLE:  CiA 402 per node, by RPDO1 controlword: a node in FAULT is an error unless
 *              cfg.fault_reset (then fault reset); SHUTDOWN -> READY, SWITCH ON -> SWITCHED
 *              ON, ENABLE OPERATION -> OPERATION ENABLED, each step confirmed by the
 *              statusword within enable_timeout_ms. The first commanded position is the
 *              actual one (CSP), so nothing jumps.
 *     RUN:     the caller streams (ef_comaster_push_target() or ef_comaster_push_move()) and
 *              calls ef_comaster_finish() after the last.
 *     FINISH:  waits until every node has executed everything and is at rest, then
 *              SHUTDOWN (operation disabled) -> DONE.
 *     STOPPING: after an error or ef_comaster_stop(): QUICK STOP to every node still enabled
 *              (its own controlled ramp), wait (stop_timeout_ms) for rest, then SHUTDOWN;
 *              ERROR (after an error) or DONE (a requested stop).
 *
 * ## Transitions (state / sub-state, ::ef_com_sub_t; "stop" is the controlled stop below)
 *
 *     from                  event                                         to
 *     (init)                ef_comaster_init()                            BOOT / BOOT_RESET
 *     BOOT / BOOT_RESET     first process(): NMT reset comm (reset_comm)  BOOT / BOOT_WAIT
 *     BOOT / BOOT_WAIT      every node heard                              CONFIG
 *     BOOT / BOOT_WAIT      boot_timeout_ms, a node silent                ERROR
 *     CONFIG                every node's steps done: NMT start, SYNC on   START
 *     CONFIG                SDO failure, check mismatch, restart          ERROR (no drive started)
 *     START                 every node's first TPDO1                      ENABLE
 *     ENABLE                every node OPERATION ENABLED                  RUN
 *     RUN                   ef_comaster_finish()                          FINISH / FINISH_DRAIN
 *     FINISH / FINISH_DRAIN all executed, at rest; CSP                    FINISH / SHUTDOWN
 *     FINISH / FINISH_DRAIN all executed, at rest; segment mode           FINISH / FINISH_RUN_OFF
 *     FINISH / FINISH_RUN_OFF bit 12 clear on every node                  FINISH / SHUTDOWN
 *     FINISH / FINISH_RUN_OFF enable_timeout_ms (error STOP)              FINISH / SHUTDOWN
 *     START..FINISH         an error or ef_comaster_stop()                STOPPING / STOP_RAMP
 *     STOPPING / STOP_RAMP  every node at rest (or lost and gone)         STOPPING / SHUTDOWN
 *     STOPPING / STOP_RAMP  stop_timeout_ms (error STOP)                  STOPPING / SHUTDOWN
 *     any / SHUTDOWN        every node out of operation (or gone), or     DONE (no error),
 *                           enable_timeout_ms (error STOP)                ERROR (an error)
 *
 * An error in BOOT or CONFIG ends in ERROR at once: SYNC is not running, so no drive moves.
 * The sub-state matters to the cycle too: the master feeds targets / segments only in RUN
 * and FINISH_DRAIN; SHUTDOWN commands SHUTDOWN (disable voltage after a quick stop).
 *
 * Supervision in every state after BOOT: heartbeat consumer (a node silent for
 * hb_timeout_ms: ::EF_ERR_HEARTBEAT), EMCY consumer (::EF_ERR_DRIVE with the code), a FAULT
 * statusword (::EF_ERR_DRIVE), a boot-up message from a running node (it restarted:
 * ::EF_ERR_DRIVE), unexpected or malformed frames from a node (counted; a malformed SDO
 * answer is ::EF_ERR_PROTO), port errors (::EF_ERR_BUS, see ef_comaster_bus_error()).
 * The first error is kept (ef_comaster_error()) and starts the controlled stop.
 *
 * ## Streaming
 * CSP: targets are queued (::EF_COM_TARGETQ); each SYNC the master sends every node its
 * next target (RPDO1: controlword + target position, applied by the drive at the following
 * SYNC). An empty queue at a SYNC repeats the last target and counts a starved cycle.
 * Segment mode: moves are queued (::EF_COM_SEGQ, kept until every node has acknowledged
 * them); the master sends the law record once and each node its axis record when every
 * node has room (credit = free places the node reported minus records in flight), at most
 * cfg.seg_per_cycle segments per SYNC; a node whose next expected sequence number has not
 * advanced for resend_cycles SYNCs after a send gets everything from that number again
 * (go-back-N; the drive ignores duplicates). SYNCs at which frames are still waiting to go
 * out (the master's TX queue, or what the port reported with ef_comaster_tx_pending()) do
 * not count: on a slow link (a USB adapter under load) what was sent may simply not have
 * left yet, and resending it would only queue it twice. Execution starts (controlword bit 4 to
 * every node in one SYNC) once cfg.prefill segments are acknowledged or finish() was called.
 *
 * ## SDO client (an ef_sdo_client_t, ef_sdo_client.h: its states and transition table)
 * One transfer at a time, to the node it names: expedited upload and download (up to 4
 * bytes), segmented upload (the server chooses), segmented download (more than 4 bytes:
 * initiate with the size indicated (s = 1, e = 0, size in bytes 4..7), the server confirms,
 * then segments of up to 7 bytes, the toggle bit starting at 0, each confirmed with the same
 * toggle; the last one carries c = 1). Every request waits sdo_timeout_ms for its answer; one
 * retry follows, which restarts the whole transfer from its initiate. A server abort is
 * ::EF_ERR_PROTO with its code; a wrong toggle bit in an answer ::EF_ERR_PROTO (abort
 * ::EF_CO_ABORT_TOGGLE), any other unexpected answer ::EF_ERR_PROTO (abort 0).
 * At CONFIG the master owns the client (its failures are the master's error, naming node and
 * object). In RUN, DONE and ERROR the caller may use it (ef_comaster_sdo_write(),
 * ef_comaster_sdo_read(), ef_comaster_sdo_result()); such a transfer continues through FINISH
 * and STOPPING, and its failure is the caller's only: no master error, no stop. A node that
 * boots again during its configuration transfer gets no retry of it (it forgot the transfer):
 * the configuration starts over.
 *
 * ## TX queue (an ef_txq_t, ef_txq.h)
 * Frames leave in the order they were sent; a full queue loses the frame being sent, never a
 * queued one (::EF_TXQ_DROP_NEWEST: a record half on the bus stays whole; the protocol
 * repairs a lost newest frame), counted in txq.lost. A frame the port refuses outright leaves
 * the queue (a retry would change nothing).
 *
 * Non-blocking: ef_comaster_rx() per received frame, ef_comaster_process(m, dt_us,
 * &next_us) for time (wrap-safe differences of a free-running microsecond counter).
 * The port's send must not call ef_comaster_rx() itself (queue received frames instead).
 *
 * ## Details (ef_comaster.c)
 * - Error codes: a CHECK mismatch and an SDO abort or malformed answer are ::EF_ERR_PROTO
 *   (abort holds the abort code), an SDO without answer after one retry ::EF_ERR_TIMEOUT;
 *   no first TPDO1 or a power step not confirmed within enable_timeout_ms is
 *   ::EF_ERR_TIMEOUT (what ENABLE, index 0x6041); go-back-N beyond max_resends is
 *   ::EF_ERR_PROTO (what STREAM, value the oldest unacknowledged sequence number); a node not
 *   at rest after stop_timeout_ms is ::EF_ERR_TIMEOUT (what STOP).
 * - BOOT with reset_comm counts only boot-up messages (a heartbeat may predate the reset); a
 *   node that boots again before its configuration completed is configured from the start.
 * - Segment mode sends RPDO1 when the controlword changes, every cycle during ENABLE,
 *   STOPPING and SHUTDOWN, and at least every 10 SYNCs otherwise. Execution starts once
 *   min(prefill, smallest ring a node reported at RUN) segments are acknowledged, or all
 *   after finish(). FINISH: all acknowledged and every node target reached, then the run bit
 *   is cleared and bit 12 awaited (at rest this is no stop), then SHUTDOWN.
 * - A process() call late by several cycles sends one SYNC and carries at most one more
 *   cycle (sent at the next call); the rest is dropped (drives step a fixed period per SYNC).
 */
#ifndef EF_COMASTER_H
#define EF_COMASTER_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/canopen/ef_sdo_client.h"
#include "evenfeed/canopen/ef_txq.h"
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most drives per master: one per axis, X Y Z A B C U V W. */
#ifndef EF_COM_MAX_NODES
#define EF_COM_MAX_NODES 9
#endif
/** CSP target queue (cycles). */
#ifndef EF_COM_TARGETQ
#define EF_COM_TARGETQ 16
#endif
/** Segment-mode queue of moves not yet acknowledged by every node. */
#ifndef EF_COM_SEGQ
#define EF_COM_SEGQ 32
#endif
/** Frames the master queues while its port is busy. */
#ifndef EF_COM_TXQ
#define EF_COM_TXQ 64
#endif
/** SDO client buffer: the longest upload kept (the device name; longer data is read and
 *  cut) and the longest download (ef_comaster_sdo_write()). It is the SDO client's
 *  ::EF_SDO_CLIENT_BUF: set either one. */
#ifndef EF_COM_SDO_BUF
#define EF_COM_SDO_BUF EF_SDO_CLIENT_BUF
#endif
#if EF_COM_SDO_BUF != EF_SDO_CLIENT_BUF
#error "EF_COM_SDO_BUF and EF_SDO_CLIENT_BUF differ: set one of them"
#endif

/** Streaming modes. */
typedef enum {
    EF_COM_MODE_CSP = 0,     /**< CiA 402 cyclic synchronous position */
    EF_COM_MODE_SEGMENT = 1, /**< evenfeed segment mode */
} ef_com_mode_t;

/** Master states. */
typedef enum {
    EF_COM_IDLE = 0, /**< not started */
    EF_COM_BOOT,
    EF_COM_CONFIG,
    EF_COM_START,
    EF_COM_ENABLE,
    EF_COM_RUN,
    EF_COM_FINISH,
    EF_COM_STOPPING,
    EF_COM_DONE,  /**< finished (or stopped on request) and disabled */
    EF_COM_ERROR, /**< stopped after an error; ef_comaster_error() says what */
} ef_com_state_t;

/** Sub-states (::ef_comaster_t::sub): where a state is in its sequence (transition table in
 *  the file comment). Each belongs to one state, except SHUTDOWN, the common end of FINISH and
 *  STOPPING. */
typedef enum {
    EF_COM_SUB_NONE = 0,       /**< CONFIG, START, ENABLE, RUN, DONE, ERROR: none */
    EF_COM_SUB_BOOT_RESET,     /**< BOOT: reset communication not sent, boot timer not begun */
    EF_COM_SUB_BOOT_WAIT,      /**< BOOT: waiting for every node's boot-up (boot_timeout_ms) */
    EF_COM_SUB_FINISH_DRAIN,   /**< FINISH: the queue executes (untimed) */
    EF_COM_SUB_FINISH_RUN_OFF, /**< FINISH, segment mode: run bit cleared, waiting for statusword
                                    bit 12 to clear (enable_timeout_ms) */
    EF_COM_SUB_STOP_RAMP,      /**< STOPPING: QUICK STOP, waiting for rest (stop_timeout_ms) */
    EF_COM_SUB_SHUTDOWN,       /**< FINISH, STOPPING: SHUTDOWN, waiting for every node to leave
                                    operation (enable_timeout_ms) */
} ef_com_sub_t;

/** What the master was doing when an error arose (::ef_com_error_t::what). */
typedef enum {
    EF_COM_WHAT_NONE = 0,
    EF_COM_WHAT_BOOT,      /**< waiting for boot-up / heartbeat */
    EF_COM_WHAT_SDO_READ,  /**< index/sub name the object */
    EF_COM_WHAT_SDO_WRITE, /**< index/sub name the object */
    EF_COM_WHAT_CHECK,     /**< a value read back is not the expected one (value holds it) */
    EF_COM_WHAT_ENABLE,    /**< power state machine (statusword holds the last one) */
    EF_COM_WHAT_HEARTBEAT, /**< heartbeat lost */
    EF_COM_WHAT_EMCY,      /**< emcy holds the code, drive_fault the drive's fault */
    EF_COM_WHAT_FAULT,     /**< statusword reports FAULT */
    EF_COM_WHAT_RESTART,   /**< boot-up message from a node already running */
    EF_COM_WHAT_BUS,       /**< port error (bus-off, error-passive, interface down) */
    EF_COM_WHAT_STREAM,    /**< segment refused / resend limit / target not representable */
    EF_COM_WHAT_STOP,      /**< a node did not come to rest in time */
} ef_com_what_t;

/** The first error, for a message that names node and object. */
typedef struct {
    int code;            /**< EF_ERR_* (0: none) */
    uint8_t what;        /**< ::ef_com_what_t */
    uint8_t node;        /**< node id (0: the bus / no node) */
    uint8_t sub;         /**< object sub-index */
    uint8_t drive_fault; /**< EMCY byte 3 (::ef_drive_fault_t) */
    uint16_t index;      /**< object index (0: none) */
    uint16_t emcy;       /**< EMCY error code */
    uint16_t statusword; /**< last statusword of the node */
    uint8_t power;       /**< ::ef_co_power_t of that statusword */
    uint8_t pad;
    uint32_t abort;    /**< SDO abort code (0: none) */
    uint32_t value;    /**< CHECK: the value read; STREAM: the sequence number; EMCY: the
                            drive's SYNC count at the fault (EMCY bytes 4..7) */
    uint32_t expected; /**< CHECK: the value expected */
} ef_com_error_t;

/** Master configuration. */
typedef struct {
    uint8_t nodes[EF_COM_MAX_NODES]; /**< node ids, node k moves axis k */
    uint8_t n_nodes;                 /**< 1..EF_COM_MAX_NODES (segment mode: at most EF_AXES) */
    uint8_t mode;                    /**< ::ef_com_mode_t */
    uint8_t reset_comm;              /**< send NMT reset communication first (default 1) */
    uint8_t fault_reset;             /**< reset a faulted drive at enable (default 0: refuse) */
    uint32_t cycle_us;               /**< SYNC period (default CSP 1000, segment 10000) */
    uint16_t hb_producer_ms;         /**< heartbeat period asked of the drives (default 50) */
    uint16_t hb_timeout_ms;          /**< a node silent this long is lost (default 200) */
    uint32_t boot_timeout_ms;        /**< default 3000 */
    uint32_t sdo_timeout_ms;         /**< per SDO request (default 200; one retry follows) */
    uint32_t enable_timeout_ms;      /**< per power-state step (default 1000) */
    uint32_t stop_timeout_ms;        /**< a controlled stop must reach rest (default 5000) */
    uint32_t ferr_window;  /**< 0x6065 written to every drive (increments, default 10000) */
    uint8_t seg_per_cycle; /**< segments sent per SYNC at most (default 4) */
    uint8_t resend_cycles; /**< SYNCs without progress before go-back-N (default 3) */
    uint8_t prefill;       /**< segments acknowledged before execution starts (default 8) */
    uint8_t pad;
    uint32_t max_resends; /**< go-back-N rounds for one node in a row, without that node
                               advancing in between, before giving up (default 50) */
} ef_com_cfg_t;

/** @brief Defaults for a mode (the cycle default depends on it); no nodes. */
void ef_comaster_cfg_default(ef_com_cfg_t *c, int mode);

/** What the master knows of one node (ef_comaster_node()). */
typedef struct {
    uint8_t id;
    uint8_t nmt;       /**< from boot-up / heartbeat (0xFF: nothing heard) */
    uint8_t power;     /**< ::ef_co_power_t (from TPDO1; ::EF_CO_PS_NOT_READY before) */
    uint8_t seen_tpdo; /**< a TPDO1 arrived since START */
    uint16_t statusword;
    uint16_t last_emcy;
    int32_t pos_inc;    /**< actual position (increments, TPDO1) */
    float pos;          /**< actual position (program units) */
    uint32_t tpdo_sync; /**< master's SYNC count when that TPDO1 arrived */
    uint32_t inc_per_unit;
    /* Segment mode. */
    uint32_t next_seq; /**< next sequence number the node expects (extended) */
    uint8_t free;      /**< free ring places it reported */
    uint8_t pad[3];
    uint32_t resends;   /**< go-back-N rounds for this node */
    uint32_t hb_age_us; /**< time since its last heartbeat */
    uint8_t hb_fresh;   /**< a heartbeat came since the last time step: it arrived during
                             that step's span, so the span does not add to hb_age_us (a
                             master starved of CPU time finds them queued, not missing) */
    uint8_t pad2[3];
    uint32_t emcy_count;
    uint32_t rx_bad; /**< malformed / unexpected frames from it */
} ef_com_node_t;

/** Master state (public for static allocation; read through the functions). */
typedef struct {
    ef_com_cfg_t cfg;
    ef_can_port_t port;
    uint8_t state; /**< ::ef_com_state_t */
    uint8_t sub;   /**< private: ::ef_com_sub_t, the step within the state */
    uint8_t cur;   /**< private: node being configured / enabled */
    uint8_t finishing;
    ef_com_node_t node[EF_COM_MAX_NODES];
    ef_com_error_t err;
    uint32_t now_us;    /**< time since init (wraps) */
    uint32_t t_step_us; /**< private: when the current state or sub-state began */
    uint32_t sync_acc_us;
    uint32_t sync_count; /**< SYNCs sent */
    /* SDO client (one transfer at a time). */
    ef_sdo_client_t sdo; /**< private: bring-up's transfers, then the caller's */
    uint8_t sdo_user;    /**< private: the pending / last transfer is the caller's */
    uint8_t sdo_pad[3];
    /* CSP. */
    float tq[EF_COM_TARGETQ][EF_COM_MAX_NODES];
    uint32_t tq_head, tq_count;
    int32_t last_target[EF_COM_MAX_NODES];
    uint32_t starved; /**< SYNCs with no target queued while running */
    /* Segment mode. */
    ef_move_t sq[EF_COM_SEGQ];
    uint32_t sq_head, sq_count; /**< sq[sq_head] has sequence number sq_base */
    uint32_t sq_base;           /**< oldest not acknowledged by every node */
    uint32_t sent_to;           /**< next sequence number to send (sq_base <= sent_to) */
    uint32_t next_seq;          /**< sequence number the next pushed move gets */
    uint32_t last_progress_sync[EF_COM_MAX_NODES];
    uint16_t cw[EF_COM_MAX_NODES]; /**< controlword being sent */
    uint8_t running;               /**< execution started (bit 4 sent) */
    uint8_t halt;                  /**< feed hold requested (bit 8 sent, ef_comaster_hold()) */
    uint8_t pad[2];
    /* TX queue: ::EF_TXQ_DROP_NEWEST, refused frames dropped (ef_txq.h says why). */
    ef_txq_t txq;                       /**< count, sent, again, lost: read only */
    ef_can_frame_t txq_buf[EF_COM_TXQ]; /**< private: its storage */
    uint32_t rx_frames;
    /* Private (ef_comaster.c). */
    uint16_t op;                    /**< configuration step of node cur */
    uint8_t cfg_restart;            /**< node cur booted again while being configured: start over */
    uint8_t sync_on;                /**< SYNC production running */
    uint8_t lost[EF_COM_MAX_NODES]; /**< heartbeat lost: not waited for when stopping once
                                         it is gone too (no TPDO1 for a few SYNCs) */
    uint8_t last_power[EF_COM_MAX_NODES]; /**< power state when its step timer started */
    uint16_t cw_sent[EF_COM_MAX_NODES];   /**< segment mode: controlword last sent */
    uint32_t t_node_us[EF_COM_MAX_NODES]; /**< ENABLE: when the node's power step began */
    uint32_t mark_sync; /**< SYNC count when the current wait began (stale TPDO filter) */
    uint32_t cw_age;    /**< segment mode: SYNCs since RPDO1 was last sent */
    uint32_t seg_cap;   /**< segment mode: smallest ring a node reported at RUN */
    uint32_t resends;   /**< go-back-N rounds, all nodes */
    uint32_t resend_run[EF_COM_MAX_NODES]; /**< private: go-back-N rounds for a node since it
                                                last advanced */
    uint32_t sync_late;                    /**< SYNC periods skipped by late process() calls */
    uint32_t port_pending; /**< frames the port took that are not on the bus yet (private:
                                ef_comaster_tx_pending()) */
    uint32_t rx_other;     /**< frames of no configured node (ignored) */
    char name[EF_COM_MAX_NODES][EF_COM_SDO_BUF + 1]; /**< 0x1008 of each node */
} ef_comaster_t;

/**
 * @brief Initialise and begin BOOT.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, no send op, node count 0 or above EF_COM_MAX_NODES, a node id not
 *                    1..127 or repeated, unknown mode, cycle_us 0, a timeout 0
 */
int ef_comaster_init(ef_comaster_t *m, const ef_com_cfg_t *c, const ef_can_port_t *port);

/**
 * @brief Handle one received frame (in DONE and ERROR only the answers to the caller's SDO
 * transfer).
 * @retval EF_OK  (unexpected frames are counted, not errors, unless they are an error's cause)
 * @retval EF_ERR_ARG NULL
 * @retval <0     the error this frame caused (also kept: ef_comaster_error())
 */
int ef_comaster_rx(ef_comaster_t *m, const ef_can_frame_t *f);

/**
 * @brief Advance time: timeouts, SDO sequence, SYNC and PDOs when due, TX retries (in DONE
 * and ERROR only TX retries and the caller's SDO transfer).
 * @param next_us out (may be NULL): when to call again at the latest (the next SYNC or
 *                timeout)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 * @retval <0     an error arose in this call (kept: ef_comaster_error())
 */
int ef_comaster_process(ef_comaster_t *m, uint32_t dt_us, uint32_t *next_us);

/** @brief Current ::ef_com_state_t. */
int ef_comaster_state(const ef_comaster_t *m);

/** @brief The first error (code 0: none). Never NULL for a non-NULL m. */
const ef_com_error_t *ef_comaster_error(const ef_comaster_t *m);

/** @brief What is known of node k (0 <= k < n_nodes; NULL otherwise). */
const ef_com_node_t *ef_comaster_node(const ef_comaster_t *m, int k);

/** @brief Device name (0x1008) node k reported at CONFIG, cut to ::EF_COM_SDO_BUF bytes,
 *  NUL-terminated ("" before it was read; NULL for a bad k). */
const char *ef_comaster_name(const ef_comaster_t *m, int k);

/**
 * @brief CSP: queue the next cycle's target for every node (program units, pos[k] for node k).
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or not CSP mode
 * @retval EF_ERR_STATE     not RUN
 * @retval EF_ERR_FULL      queue full: process first
 * @retval EF_ERR_NONFINITE a target not finite or beyond int32 increments
 */
int ef_comaster_push_target(ef_comaster_t *m, const float *pos);

/**
 * @brief Segment mode: queue a move (its seq is replaced by the master's numbering).
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL, not segment mode, or a move the drives would refuse (degree,
 *                      non-finite data, duration)
 * @retval EF_ERR_STATE not RUN
 * @retval EF_ERR_FULL  queue full: process first
 */
int ef_comaster_push_move(ef_comaster_t *m, const ef_move_t *mv);

/** @brief Free places in the active queue (targets or moves). */
uint32_t ef_comaster_space(const ef_comaster_t *m);

/**
 * @brief Segment mode: feed hold (on != 0) or resume. Controlword bit 8 (halt,
 * ::EF_CO_CW_HALT) goes to every node in the same cycle while RUN or FINISH; the drives
 * decelerate along the path and stand, and resume where they stood when it clears. Segments
 * keep flowing into the drives' rings meanwhile. A level: stopping or finishing keeps it.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, or CSP (there the caller's targets are the path: it slows them)
 */
int ef_comaster_hold(ef_comaster_t *m, int on);

/**
 * @brief No more input: execute what is queued, come to rest, disable (FINISH -> DONE).
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE not RUN
 */
int ef_comaster_finish(ef_comaster_t *m);

/**
 * @brief Controlled stop on request (STOPPING -> DONE); no effect when already stopping,
 * DONE or ERROR.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_comaster_stop(ef_comaster_t *m);

/**
 * @brief The port reports a bus error (bus-off, error-passive, interface down): an
 * ::EF_ERR_BUS error (what BUS, `detail` in value) and a controlled stop (frames are still
 * sent, so a bus that recovers carries the stop).
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_comaster_bus_error(ef_comaster_t *m, uint32_t detail);

/**
 * @brief The port holds `frames` that it took and has not yet put on the bus (a host
 * transport's software queue and unconfirmed frames; 0 for a controller that says nothing).
 * While frames are pending, segment mode's go-back-N does not count a node's lack of
 * progress (what was sent may not have left). Task context, before ef_comaster_process().
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_comaster_tx_pending(ef_comaster_t *m, uint32_t frames);

/**
 * @brief Start an SDO download of len bytes to object index:sub of node k (0-based index
 * into cfg.nodes): expedited for up to 4 bytes, segmented otherwise. The data is copied;
 * ef_comaster_sdo_result() tells the outcome.
 * @retval EF_OK        started
 * @retval EF_ERR_ARG   NULL m or data, k not 0..n_nodes-1, len 0 or above ::EF_COM_SDO_BUF
 * @retval EF_ERR_STATE a transfer is pending, or the master is not in RUN, DONE or ERROR
 *                      (during bring-up the master owns the SDO client)
 */
int ef_comaster_sdo_write(ef_comaster_t *m, int k, uint16_t index, uint8_t sub, const uint8_t *data,
                          uint32_t len);

/**
 * @brief Start an SDO upload of object index:sub of node k (0-based index into cfg.nodes):
 * expedited or segmented, as the server answers; data beyond ::EF_COM_SDO_BUF bytes is read
 * and cut. ef_comaster_sdo_result() tells the outcome and gives the data.
 * @retval EF_OK        started
 * @retval EF_ERR_ARG   NULL m, k not 0..n_nodes-1
 * @retval EF_ERR_STATE a transfer is pending, or the master is not in RUN, DONE or ERROR
 */
int ef_comaster_sdo_read(ef_comaster_t *m, int k, uint16_t index, uint8_t sub);

/**
 * @brief Outcome of the last transfer started by ef_comaster_sdo_write() or
 * ef_comaster_sdo_read(). A failure is the caller's only: it is not the master's error
 * (ef_comaster_error()) and does not stop motion. Every out pointer may be NULL.
 * @param abort out: the server's abort code (::EF_CO_ABORT_TOGGLE for a wrong toggle bit in
 *              an answer), 0 otherwise
 * @param data  out: a read's bytes (valid until the next transfer starts); NULL otherwise
 * @param len   out: their count (at most ::EF_COM_SDO_BUF); 0 otherwise
 * @retval EF_OK          done (a read's data in data/len)
 * @retval EF_ERR_AGAIN   pending: call ef_comaster_process() / ef_comaster_rx() on
 * @retval EF_ERR_PROTO   the server aborted (code in *abort), or a malformed answer or wrong
 *                        toggle bit
 * @retval EF_ERR_TIMEOUT no answer, also not to the one retry
 * @retval EF_ERR_STATE   no such transfer was started
 * @retval EF_ERR_ARG     NULL m
 */
int ef_comaster_sdo_result(const ef_comaster_t *m, uint32_t *abort, const uint8_t **data,
                           uint32_t *len);

#ifdef __cplusplus
}
#endif

#endif /* EF_COMASTER_H */
