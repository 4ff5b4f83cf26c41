/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_mb.h
 * @brief Modbus transport on libmodbus (TCP and RTU): the master that streams segments
 * to a drive, and the simulated drive server (docs/modbus.md).
 *
 * The master writes whole segment slots with FC16, one transaction per slot, and keeps the
 * ring fed by reading the drive's free count. Every transaction is retried on a timeout,
 * a corrupt reply or a lost connection (reconnecting); retries are idempotent because each
 * slot carries its sequence number and the drive acknowledges a number it already has
 * without executing it twice. Exception replies are mapped to errors that name the
 * register and the exception. A drive that reports a fault, or that restarted (its session
 * number changed), stops the stream with ::EF_ERR_DRIVE.
 *
 * Errors: ef_err codes plus a one-line message (ef_host.h).
 */
#ifndef EF_MB_H
#define EF_MB_H

#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include "evenfeed/modbus/ef_modbus.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/program/ef_pipeline.h"

#ifdef __cplusplus
extern "C" {
#endif

/** ef_mb_cfg_t::axis of an X Y Z drive (3 axes per slot). */
#define EF_MB_AXIS_XYZ 0
/** Largest ef_mb_cfg_t::axis: 1..9 are x y z a b c u v w. */
#define EF_MB_AXIS_MAX 9
/** Most drives one stream takes (nine single-axis drives). */
#define EF_MB_MAX_DRIVES 9

/** Where a drive is and how to talk to it. */
typedef struct {
    int rtu;              /**< 0: Modbus TCP, 1: Modbus RTU */
    char host[128];       /**< TCP: address */
    int port;             /**< TCP: port (0 for a server: any free port) */
    char device[256];     /**< RTU: serial device */
    int baud;             /**< RTU: baud rate */
    char parity;          /**< RTU: 'N', 'E' or 'O' */
    int data_bits;        /**< RTU: 7 or 8 */
    int stop_bits;        /**< RTU: 1 or 2 */
    int slave;            /**< unit id / slave address (1..247) */
    double timeout_s;     /**< response timeout per transaction (s) */
    int retries;          /**< further attempts after a failed transaction */
    double reconnect_s;   /**< how long to keep trying to reconnect (s) */
    uint16_t watchdog_ms; /**< the drive's watchdog while streaming (0: off) */
    /** What the drive carries: ::EF_MB_AXIS_XYZ (0, default) a 3-axis drive (register
     *  0x0002 reads 3), 1..9 one axis of x y z a b c u v w on a single-axis drive (0x0002
     *  reads 1). ef_mb_open() refuses a drive that reports the other kind. */
    int axis;
    /** Optional, called before every status poll (also in the master's waits for free
     *  slots and for the drain), from the caller's thread: nonzero stops what the master was
     *  doing with that code (the message in m). The machine I/O's e-stop check. */
    int (*on_poll)(void *user, ef_msg_t *m);
    void *on_poll_user;
} ef_mb_cfg_t;

/** Defaults: slave 1, timeout 0.2 s, 3 retries, reconnect 2 s, watchdog 1000 ms, RTU
 *  115200 8N1, an X Y Z drive. */
void ef_mb_cfg_default(ef_mb_cfg_t *c);

/**
 * @brief Parse "tcp://HOST:PORT" or "rtu:DEVICE[,BAUD[,8N1]]" into c (other fields kept).
 * @retval EF_OK
 * @retval EF_ERR_ARG malformed (message says which part)
 */
int ef_mb_url_parse(const char *url, ef_mb_cfg_t *c, ef_msg_t *m);

/**
 * @brief Parse what a drive carries: "xyz", or one letter of x y z a b c u v w (either case).
 * @retval EF_OK      *axis set (::EF_MB_AXIS_XYZ, or 1..9)
 * @retval EF_ERR_ARG anything else
 */
int ef_mb_axis_parse(const char *s, int *axis);

/** @brief "xyz", "x" .. "w" for ef_mb_cfg_t::axis ("?" out of range). */
const char *ef_mb_axis_name(int axis);

/** A drive's status block as the master last read it. */
typedef struct {
    uint16_t session, status, state, fault, free, slots;
    uint32_t next_seq, done_seq, exec_seq, time_ms, done_count;
    uint16_t rejected, duplicates;
    float act[3], cmd[3], ferr_max;
} ef_mb_status_t;

/** Counters of a master. */
typedef struct {
    uint64_t transactions;  /**< requests sent (retries included) */
    uint64_t slot_writes;   /**< slots acknowledged */
    uint64_t target_writes; /**< direct targets acknowledged */
    uint64_t polls;         /**< status reads */
    uint64_t retries;       /**< transactions repeated */
    uint64_t timeouts;      /**< of which after a timeout */
    uint64_t reconnects;    /**< connections re-established */
    uint64_t busy;          /**< status reads that found no free slot (a BUSY answer leads
                                 to such a read) */
    double t_first, t_last; /**< monotonic seconds of the first and last slot write */
} ef_mb_stats_t;

typedef struct ef_mb_master ef_mb_master_t;

/**
 * @brief Connect, read and check the identification block.
 * @retval EF_OK
 * @retval EF_ERR_ARG        bad configuration
 * @retval EF_ERR_NOMEM      allocation failed
 * @retval EF_ERR_DISCONNECT could not connect
 * @retval EF_ERR_TIMEOUT    no answer
 * @retval EF_ERR_PROTO      not an evenfeed drive (magic, version, slot size) or an
 *                           exception reply
 */
int ef_mb_open(const ef_mb_cfg_t *c, ef_mb_master_t **out, ef_msg_t *m);

/** @brief Close the connection and free the master (NULL is ignored). */
void ef_mb_close(ef_mb_master_t *ms);

/**
 * @brief Read the status block (also checks the session: a restart is ::EF_ERR_DRIVE).
 * @retval EF_OK, EF_ERR_TIMEOUT, EF_ERR_DISCONNECT, EF_ERR_PROTO, EF_ERR_DRIVE
 */
int ef_mb_read_status(ef_mb_master_t *ms, ef_mb_status_t *st, ef_msg_t *m);

/**
 * @brief Prepare the drive for a stream: refuse a faulted drive (never enable a drive
 * whose state is not known to be clean), write the mode and watchdog, then CLEAR|ENABLE in
 * one command, and check it reports ENABLED with an empty ring.
 * @param mode ::EF_MB_MODE_SEGMENT or ::EF_MB_MODE_DIRECT
 * @retval EF_OK
 * @retval EF_ERR_DRIVE the drive is in fault (message: code) or did not enable
 * @retval others       as ef_mb_read_status()
 */
int ef_mb_begin(ef_mb_master_t *ms, int mode, ef_msg_t *m);

/**
 * @brief Send one segment (blocks while the ring is full). The first segment must start
 * where the drive's command is. Starts the drive once the ring is full.
 * @retval EF_OK
 * @retval EF_ERR_ARG   the segment cannot be encoded, or the first does not start at the
 *                      drive's position (message gives both)
 * @retval EF_ERR_DRIVE the drive faulted or restarted (message: code, sequence numbers)
 * @retval EF_ERR_PROTO an exception reply other than BUSY (message: exception, seq)
 * @retval EF_ERR_TIMEOUT, EF_ERR_DISCONNECT  retries and reconnection exhausted
 */
int ef_mb_send(ef_mb_master_t *ms, const ef_move_t *mv, ef_msg_t *m);

/**
 * @brief Start the drive if not yet, and wait until every segment sent has executed and
 * the drive is at rest.
 * @retval as ef_mb_send()
 */
int ef_mb_drain(ef_mb_master_t *ms, ef_msg_t *m);

/**
 * @brief Direct mode: write one target position (6 registers, one FC16).
 * @retval as ef_mb_send()
 */
int ef_mb_target(ef_mb_master_t *ms, const float p[3], ef_msg_t *m);

/**
 * @brief Reset a drive's fault (FAULT -> DISABLED), only on the user's explicit request; a
 * drive not in FAULT is left alone.
 * @retval EF_OK, or as ef_mb_read_status(); EF_ERR_DRIVE if it is still in fault after
 */
int ef_mb_fault_reset(ef_mb_master_t *ms, ef_msg_t *m);

/**
 * @brief Segment mode: feed hold (on != 0) or resume (::EF_MB_CTL_HOLD, a level every
 * later enabling control word keeps). The drive decelerates along the path and stands; the
 * status says ::EF_MB_ST_HELD once it does. A request equal to the last is not written.
 * @retval EF_OK
 * @retval EF_ERR_STATE not begun in segment mode
 * @retval others as the control write (the drive refused it, connection)
 */
int ef_mb_hold(ef_mb_master_t *ms, int on, ef_msg_t *m);

/**
 * @brief Several drives: ef_mb_send() never writes START itself (on != 0); the caller fills
 * every drive's ring, then starts them back to back with ef_mb_start(). A send that finds
 * the ring full before the start fails (::EF_ERR_STATE) rather than wait.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_mb_set_manual_start(ef_mb_master_t *ms, int on);

/**
 * @brief Segment mode: write START unless the drive was started.
 * @retval EF_OK
 * @retval EF_ERR_STATE not begun in segment mode
 * @retval others as the control write
 */
int ef_mb_start(ef_mb_master_t *ms, ef_msg_t *m);

/**
 * @brief A status read with the checks of the stream (a fault, a restart, a drive that
 * left ENABLED before the start or RUNNING after it); ef_mb_cfg_t::on_poll runs first.
 * @retval EF_OK
 * @retval EF_ERR_DRIVE the drive faulted, restarted or left its state (message says)
 * @retval others as ef_mb_read_status(), or on_poll's code
 */
int ef_mb_poll(ef_mb_master_t *ms, ef_msg_t *m);

/** @brief Whether START was written (0 for NULL). */
int ef_mb_started(const ef_mb_master_t *ms);

/** @brief Segments acknowledged since the begin (0 for NULL). */
uint32_t ef_mb_sent(const ef_mb_master_t *ms);

/** @brief Slots in the drive's ring, from its identification (0 for NULL). */
uint32_t ef_mb_slots(const ef_mb_master_t *ms);

/** @brief Best effort controlled stop (quick stop command); the drive's answer is ignored
 *  beyond being logged in m. */
int ef_mb_quick_stop(ef_mb_master_t *ms, ef_msg_t *m);

/** @brief Disable the drive (after a drain). */
int ef_mb_end(ef_mb_master_t *ms, ef_msg_t *m);

/** @brief The master's counters. */
const ef_mb_stats_t *ef_mb_stats(const ef_mb_master_t *ms);

/** @brief Last status read. */
const ef_mb_status_t *ef_mb_last_status(const ef_mb_master_t *ms);

/** @brief Monotonic clock (s). */
double ef_mb_now(void);

/** What evenfeed stream --modbus does, as a library call (CLI and tests). */
typedef struct {
    ef_mb_cfg_t mb;
    ef_pipe_cfg_t pipe;
    int mode;         /**< EF_MB_MODE_SEGMENT or EF_MB_MODE_DIRECT */
    double direct_hz; /**< direct mode: target writes per second of path time */
    int verbose;      /**< print progress to stderr */
    int fault_reset;  /**< reset a faulted drive before beginning (else refuse it) */
    /** Called with every move before it is sent (may be NULL; nonzero stops). */
    int (*on_move)(void *user, const ef_move_t *mv);
    void *user;
    /** Several drives, one per axis (or one X Y Z drive and single-axis ones): 0 or 1
     *  streams to the one drive in mb, as before; 2..::EF_MB_MAX_DRIVES to drives[0..n-1]
     *  (mb is then not used). Each drive's ef_mb_cfg_t::axis says what it carries; X Y Z
     *  must be carried once each, and the auxiliary axes from A on without a gap (the
     *  pipeline's naux is their count). Segment mode only. */
    int n_drives;
    ef_mb_cfg_t drives[EF_MB_MAX_DRIVES];
    /** Several drives: largest difference of their executed times (register 0x002C) at a
     *  status poll before every drive is stopped (s; default 0.02). Modbus has no SYNC:
     *  each drive runs on its own clock from its START. */
    double skew_max_s;
    /** Machine I/O (ef_mio.h), open and SAFE; NULL: none. Armed before the drive is
     *  contacted (an active e-stop, latch or alarm refuses the stream: nothing is written),
     *  read at every poll and setpoint; a trip stops the drive under control (the disable
     *  command: its stop ramp), waits for rest and drops enable: ::EF_ERR_ESTOP naming the
     *  input and the program line. M62-M65 switch its outputs at their points. Feed hold:
     *  segment mode holds the drive (ef_mb_hold()); direct mode slows its targets through a
     *  time warp (ef_warp.h), as CAN CSP does. */
    struct ef_mio_s *mio;
} ef_mb_stream_cfg_t;

/** Defaults: ef_mb_cfg_default(), ef_pipe_cfg_default() with the tables g2 and g1, segment
 *  mode, 50 targets/s in direct mode, no callback, one drive, skew bound 20 ms. */
void ef_mb_stream_cfg_default(ef_mb_stream_cfg_t *c, const ef_table_t *g2, const ef_table_t *g1);

/** Result of a stream. */
typedef struct {
    uint32_t moves;      /**< segments sent */
    uint32_t targets;    /**< direct targets sent */
    double path_time;    /**< sum of the durations (s) */
    double wall_time;    /**< from the start of smoothing to the drained end (s) */
    ef_mb_stats_t io;    /**< the (first) drive's master's counters */
    ef_mb_status_t last; /**< the (first) drive's status at the end */
    uint32_t n_drives;   /**< drives streamed to (1 for the one drive in mb) */
    ef_mb_status_t drive[EF_MB_MAX_DRIVES];   /**< each drive's status at the end */
    ef_mb_stats_t drive_io[EF_MB_MAX_DRIVES]; /**< each drive's master's counters */
    double skew_max_s;    /**< several drives: largest executed-time difference seen (s) */
    uint32_t skew_checks; /**< several drives: status rounds whose skew was measured */
    int failed_drive;     /**< index of the drive an error came from, -1: none or not one */
    uint32_t outputs;     /**< M62-M65 outputs switched (machine I/O) */
    uint32_t estop_line;  /**< after an e-stop: the program line being executed (0: none) */
    uint32_t holds;       /**< feed holds begun (machine I/O) */
    double held_s;        /**< time held (s): segment mode, the drive reporting it stands;
                               direct mode, the targets given at rate 0 */
    ef_pipe_stats_t pipe;
} ef_mb_stream_result_t;

/**
 * @brief Smooth a program and stream it: open, begin, send every move (or targets), drain,
 * disable. On any error after the drive was enabled it asks for a quick stop.
 * Several drives (ef_mb_stream_cfg_t::n_drives): each gets every move (its axis's values),
 * same sequence numbers and time law; every ring is filled, then every drive started back
 * to back; any drive's fault, restart or silence, or executed times apart by more than
 * skew_max_s, quick-stops every drive, and the message names the drive.
 * @retval EF_OK or the first error (message says what and where)
 * @retval EF_ERR_ARG a bad drive list (an axis carried twice, X Y Z not all carried, a gap
 *                    in the auxiliary axes, direct mode), before any drive is contacted
 */
int ef_mb_stream(ef_gcode_t *r, const ef_mb_stream_cfg_t *c, ef_mb_stream_result_t *res,
                 ef_msg_t *m);

/** Simulated drive server configuration. */
typedef struct {
    ef_mb_cfg_t mb; /**< where to listen (TCP host:port, or the RTU device) */
    int axes;       /**< axes per slot: 3 (an X Y Z drive, the default) or 1 (a single-axis
                         drive: its axis is x, home[1] and home[2] must be 0) */
    ef_servo_cfg_t servo;
    float home[3];
    uint32_t period_us;
    double time_scale; /**< drive time per wall time (1: real time) */
    const char *trace; /**< CSV trace of every period while enabled (NULL: none) */
    FILE *ready;       /**< where to print the "ready ..." line (NULL: stdout) */
    int wire_baud;     /**< RTU: hold each reply for the request's and reply's time
                            on a wire of this baud rate (0: off) */
    /* Fault injection; -1 disables each. */
    long exception_seq; /**< answer the first write of this slot seq with exception_code */
    int exception_code;
    long drop_reply_seq; /**< execute the first write of this seq but send no reply */
    long disconnect_seq; /**< execute the first write of this seq, then drop the client */
    double fault_at_s;   /**< raise an injected fault at this drive time (s) */
    /** The drive's own I/O (ef_drvio.h; NULL: none): its hardware enable (STO) input, read
     *  every loop round (0 while the power stage is on: ::EF_DRV_FAULT_STO), and its alarm
     *  output (1 while in fault). CHIP:LINE or LINE. */
    const char *sto_line, *alarm_line;
    volatile sig_atomic_t *stop; /**< set by a signal handler to end the server */
} ef_mb_server_cfg_t;

/** Defaults: TCP 127.0.0.1:1502, 3 axes, servo defaults, home 0, 1000 us, real time, no
 *  faults. */
void ef_mb_server_cfg_default(ef_mb_server_cfg_t *c);

/**
 * @brief Run the simulated drive until *c->stop is set (then EF_OK).
 * @retval EF_OK
 * @retval EF_ERR_IO listen/open failed (message says why)
 */
int ef_mb_serve(const ef_mb_server_cfg_t *c, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_MB_H */
