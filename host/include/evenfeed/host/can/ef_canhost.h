/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canhost.h
 * @brief CANopen over SocketCAN on the host: `evenfeed stream --can` (the master streaming a
 * part program to up to three CiA 402 drives, in CSP or evenfeed segment mode) and
 * `evenfeed sim-drive can` (one simulated drive on the bus).
 *
 * Both run the freestanding protocol code (ef_comaster.h, ef_codrive.h) over a raw CAN
 * socket (ef_sockcan.h), with the host's monotonic microsecond clock; neither sleeps: each
 * waits in the socket's receive with the timeout the protocol code asks for.
 *
 * Errors: EF_ERR_* codes plus a one-line message in ::ef_msg_t naming the interface, the
 * node and the object (host convention, ef_host.h).
 */
#ifndef EF_CANHOST_H
#define EF_CANHOST_H

#include <signal.h>
#include <stdint.h>
#include <stdio.h>

#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/host/can/ef_canif.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/program/ef_pipeline.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Axes (and so drives) a part program can move: X Y Z, then A B C U V W (EF_AXES). */
#define EF_CAN_STREAM_MAX_NODES EF_AXES
/** Longest device name (0x1008) kept per node, with its terminating NUL. */
#define EF_CAN_NAME_LEN 64

/** What `evenfeed stream --can` does, as a library call. */
typedef struct {
    const char *iface;                      /**< CAN interface, e.g. "vcan0" (required) */
    uint8_t nodes[EF_CAN_STREAM_MAX_NODES]; /**< node ids; node k moves axis k (x, y, z, then
                                                 A B C U V W: docs/axes.md) */
    uint8_t n_nodes;                        /**< 1..EF_CAN_STREAM_MAX_NODES (default 3: nodes
                                                 1, 2, 3); above 3 the smoother's naux is
                                                 n_nodes - 3 (pipe.naux is replaced) */
    uint8_t mode;                           /**< ::ef_com_mode_t (default segment) */
    uint8_t fault_reset;                    /**< reset faulted drives at enable (default 0) */
    uint8_t verbose;                        /**< progress on stderr */
    uint32_t cycle_us;          /**< SYNC period; 0: the mode's default (CSP 1000, segment 10000) */
    ef_pipe_cfg_t pipe;         /**< smoothing; in CSP mode its interpolator runs at cycle_us */
    const char *log;            /**< candump log file of the bus traffic (NULL: none) */
    const char *trace;          /**< stream trace CSV (NULL: none; format in docs/can.md) */
    uint32_t boot_timeout_ms;   /**< a node that has not booted by then is lost (3000) */
    uint32_t hb_timeout_ms;     /**< a node silent this long is lost (200) */
    uint32_t sdo_timeout_ms;    /**< per SDO request (200) */
    uint32_t enable_timeout_ms; /**< per power-state step at enable (1000) */
    uint32_t stop_timeout_ms;   /**< a controlled stop must reach rest (5000) */
    uint32_t bringup_ms;        /**< from the socket's opening to RUN at most (20000) */
    uint32_t stall_ms;          /**< a full queue that does not drain for this long plus the
                                     longest move's duration is an error (10000) */
    uint32_t bitrate;           /**< for the bus-load figure only (1000000; vcan has none) */
    const ef_canif_t *canif;    /**< the transport (ef_canif.h), opened on iface and closed by
                                     the stream; NULL: SocketCAN (ef_sockcan_canif()) */
    struct ef_mio_s *mio;       /**< machine I/O (ef_mio.h), open and SAFE; NULL: none. Armed
                                     before the bus is touched (an active e-stop, latch or alarm
                                     refuses the stream: nothing is sent), read every pump round;
                                     a trip stops every drive under control (quick stop), waits
                                     for rest (its stop_ms) and drops enable: ::EF_ERR_ESTOP
                                     naming the input and the program line. Disarmed at the end */
} ef_can_stream_cfg_t;

/** Defaults as documented per field; the pipeline is ef_pipe_cfg_default() with the tables
 *  g2 and g1. */
void ef_can_stream_cfg_default(ef_can_stream_cfg_t *c, const ef_table_t *g2, const ef_table_t *g1);

/** Result of a stream (filled also after an error, as far as it got). */
typedef struct {
    uint32_t moves;    /**< planned moves (segment mode: each pushed to the master) */
    uint32_t segments; /**< segment mode: moves the master accepted (pushed) */
    uint32_t targets;  /**< CSP: targets pushed */
    uint32_t executed; /**< segments (CSP: targets) executed: all pushed once the master
                            reached DONE after finish (it waits for every node at rest);
                            after an error: CSP the targets applied at a SYNC, segment
                            mode the segments every drive had received (an upper bound) */
    uint32_t resends;  /**< go-back-N rounds, all nodes */
    uint32_t starved;  /**< CSP: SYNCs with no target queued while running */
    uint32_t syncs;    /**< SYNCs sent */
    double sync_mean_us, sync_std_us, sync_min_us, sync_max_us; /**< SYNC periods (jitter) */
    uint64_t tx_frames, tx_bits; /**< frames and bits (ef_can_frame_bits) the master sent */
    uint64_t rx_frames, rx_bits; /**< frames and bits the master received */
    double bus_time_s;           /**< tx_bits / bitrate: the master's bus time */
    double load;                 /**< (tx_bits + rx_bits) / bitrate / wall_time */
    double path_time;            /**< sum of the moves' durations (s) */
    double wall_time;            /**< from the socket's opening to the end (s) */
    double run_time;             /**< from RUN to the end (s) */
    int state;                   /**< the master's final ::ef_com_state_t */
    ef_com_error_t err;          /**< the master's first error (code 0: none) */
    uint32_t err_frames;         /**< error frames seen on the socket */
    uint32_t rx_overrun;         /**< frames dropped by the master's full receive queue */
    uint32_t outputs;            /**< M62-M65 outputs switched (machine I/O) */
    double out_err_max;          /**< largest distance of the axes from the commanded point
                                      when an output switched (mm) */
    uint32_t holds;              /**< feed holds begun */
    double held_s;               /**< time at rest in feed holds (s; segment mode: every
                                      drive reporting it stands, statusword bit 14) */
    uint32_t estop_line;         /**< after an e-stop: program line being executed (0: none) */
    double estop_latency_s;      /**< after an e-stop: input edge to the stop command (s) */
    double estop_rest_s;         /**< after an e-stop: input edge to all drives at rest (s;
                                      < 0: not at rest when enable dropped) */
    char names[EF_CAN_STREAM_MAX_NODES][EF_CAN_NAME_LEN]; /**< device names (0x1008) read at
                                                              configuration ("" if not) */
    ef_pipe_stats_t pipe;
    /* The following error is not known to the master (the drives' traces have it). */
} ef_can_stream_result_t;

/**
 * @brief Smooth a program and stream it over CANopen: open the socket, bring the drives up
 * (boot, configuration, enable), stream segments or CSP targets, finish, disable. After any
 * error once the drives may be enabled, every drive is brought to a controlled stop and
 * disabled before returning (bounded by stop_timeout_ms).
 * @param r   reader (ef_gcode_open())
 * @param c   configuration
 * @param res result (required)
 * @param m   message (may be NULL)
 * @retval EF_OK            every segment (target) executed, drives at rest and disabled
 * @retval EF_ERR_ARG       bad configuration (nodes, mode, interface name), or the path does
 *                          not start where the drives are
 * @retval EF_ERR_NOMEM     no memory for the master
 * @retval EF_ERR_IO        no CAN in the kernel, no such interface, log or trace not
 *                          writable, a socket error
 * @retval EF_ERR_HEARTBEAT a node never booted or its heartbeat stopped ("node N: ...")
 * @retval EF_ERR_PROTO     an SDO abort or malformed answer ("node N: SDO abort 0x... (text)
 *                          writing 0xIIII:SS")
 * @retval EF_ERR_DRIVE     a drive is not what it must be, faulted (EMCY), restarted, or
 *                          refused to enable ("node N: EMCY 0xCCCC (text), drive fault F, at
 *                          SYNC S")
 * @retval EF_ERR_BUS       bus-off, error-passive or interface down ("IFACE: bus-off")
 * @retval EF_ERR_TIMEOUT   no RUN within bringup_ms, a stalled queue, or no rest in time
 * @retval other            the pipeline's error (G-code, smoothing), after a controlled stop
 */
int ef_can_stream(ef_gcode_t *r, const ef_can_stream_cfg_t *c, ef_can_stream_result_t *res,
                  ef_msg_t *m);

/**
 * @brief One line for a master error: "node 2: EMCY 0xFF04 (fault injected), drive fault 4,
 * at SYNC 1234", "node 1: heartbeat lost (200 ms)", "vcan0: bus-off"...
 * @param e     the master's error (for an EMCY, value is printed as the drive's SYNC count
 *              at the fault, from the EMCY's payload)
 * @param c     the master's configuration (timeouts named in the text; may be NULL)
 * @param iface interface name for bus errors (may be NULL)
 */
void ef_can_error_text(const ef_com_error_t *e, const ef_com_cfg_t *c, const char *iface, char *buf,
                       size_t n);

/** Most --drop-rx entries. */
#define EF_CAN_SIM_MAX_DROPS 32

/** Simulated drive configuration (`evenfeed sim-drive can`). */
typedef struct {
    const char *iface; /**< CAN interface (required) */
    uint8_t node;      /**< node id 1..127 (required) */
    float home;        /**< position at power-up (units) */
    const char *trace; /**< trace CSV (NULL: none; format in docs/can.md) */
    const char *log;   /**< candump log of what the drive sees and sends (NULL: none) */
    FILE *ready;       /**< where the "ready can NODE IFACE" line goes (NULL: stdout) */
    /* Fault injection at SYNC time in OPERATION ENABLED (SYNCs counted in that power state
     * times the cycle period 0x1006), each once; -1 off. */
    long fault_at_ms;   /**< inject EF_DRV_FAULT_INJECTED (EMCY 0xFF04) */
    long hb_stop_at_ms; /**< stop the heartbeat */
    long bus_off_at_ms; /**< send an error frame CAN_ERR_FLAG | CAN_ERR_BUSOFF on the bus */
    uint32_t drop_rx[EF_CAN_SIM_MAX_DROPS]; /**< K-th (1-based) segment chunk frames received
                                                 (RPDO2 of this node or the law COB-ID) that
                                                 are dropped */
    uint32_t n_drop;
    long run_ms;          /**< stop after this much wall time (-1: until *stop) */
    long sync_timeout_ms; /**< 0x2003 at power-up (-1: the drive's default, 500) */
    /** The drive's own I/O (ef_drvio.h; NULL: none): its hardware enable (STO) input, read
     *  every SYNC and loop round (0 while the power stage is on: EF_DRV_FAULT_STO, EMCY
     *  0xFF06), and its alarm output (1 while in fault). CHIP:LINE or LINE. */
    const char *sto_line, *alarm_line;
    volatile sig_atomic_t *stop; /**< set by a signal handler to end the loop (may be NULL) */
} ef_can_sim_cfg_t;

/** @brief Defaults: no interface, node 0 (both must be set), home 0, no trace, no log,
 *  no fault injection, run until *stop. */
void ef_can_sim_cfg_default(ef_can_sim_cfg_t *c);

/**
 * @brief Run the simulated drive: open the socket, print "ready can NODE IFACE" (flushed),
 * then serve until *c->stop is set or run_ms elapsed.
 * @retval EF_OK      stopped on request (signal) or after run_ms
 * @retval EF_ERR_ARG no interface, node not 1..127, bad servo configuration
 * @retval EF_ERR_IO  no CAN in the kernel, no such interface, trace or log not writable, a
 *                    socket error
 */
int ef_can_sim_run(const ef_can_sim_cfg_t *c, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANHOST_H */
