/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_drive.h
 * @brief Drive side: executes streamed Bézier segments with a servo model.
 *
 * What a drive that takes whole segments runs (the simulated Modbus and CAN drives, and a
 * real drive's firmware): a ring of received segments (::EF_DRIVE_SLOTS), the interpolator
 * (ef_interp.h) that evaluates them every servo period, and a servo model whose actual
 * position follows the command with lag and limits, so a following error exists and is
 * measured.
 *
 * Segments are ::ef_move_t as the smoother emits them; a drive uses only these fields:
 * `seq`, `degree`, `flags` (::EF_MOVE_STOP_END), `b[0..degree]`, `length`, `v_exit`,
 * `duration` and `law`. They carry sequence numbers 0, 1, 2, ... after a clear; a segment
 * whose number was already accepted is acknowledged and not queued again
 * (::EF_ERR_DUP), so a transport may retry a write whose answer it lost.
 *
 * States (::ef_drive_state_t):
 *
 *     DISABLED --enable--> ENABLED --start--> RUNNING (waits at rest when the queue is done)
 *         ^                   |  ^               |
 *         +------disable------+  +--STOPPING <---+ quick stop (disable: ends DISABLED)
 *     FAULT <--- STOPPING <--- any fault (underrun, following error, watchdog, injected)
 *     FAULT --fault reset (at rest)--> DISABLED
 *
 * In RUNNING the drive executes queued segments; when the queue runs dry after a segment
 * that ends at rest it waits (still RUNNING) for more. Running dry while moving is an
 * underrun fault. Every stop is controlled: the command keeps its direction and
 * decelerates at `a_stop` to rest (STOPPING), the servo follows; then ENABLED (quick stop)
 * or FAULT (a fault). Motion is commanded only in RUNNING and STOPPING; DISABLED and FAULT
 * hold nothing (the servo's command is frozen where it stopped).
 *
 * Feed hold (::ef_drive_hold): the drive keeps executing its segments, only slower: the
 * interpolator's time advances by a rate that ramps from 1 to 0 (a hold) or back (a
 * resume) along a smoothstep over T = max(::EF_DRIVE_HOLD_RAMP_MIN_US, 3 v / a_stop), v the
 * law's speed where the ramp begins, so the deceleration the hold adds peaks at
 * 1.5 v / T <= a_stop / 2. The axes decelerate along the path and stand on it; a resume
 * continues exactly there, nothing skipped or repeated. Drives that share a time law (CAN
 * drives in segment mode get one law for all axes) and switch the hold in the same period
 * stay on the path together. The state stays RUNNING throughout; a hold at rest (nothing
 * moving) takes effect at once. A quick stop or a fault during a hold stops as ever.
 *
 * Direct mode (::ef_drive_set_target): for drives streamed plain target positions, the
 * command is moved towards the latest target by a profile limited to the servo's v/a, as
 * a simple drive's own profile generator would. In direct mode the drive follows its
 * target while ENABLED (there is no queue to start); a quick stop or fault stops the
 * profile under control as above.
 *
 * Non-blocking: ef_drive_process(d, dt_us, &next_us) advances by dt_us (a difference of a
 * free-running counter, so wrap is harmless), stepping the servo model at the period.
 */
#ifndef EF_DRIVE_H
#define EF_DRIVE_H

#include <stdint.h>
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Segments a drive buffers ahead of the interpolator (its receive ring). */
#ifndef EF_DRIVE_SLOTS
#define EF_DRIVE_SLOTS 16
#endif

/** Most servo periods one ef_drive_process() call steps (a late call catches up this far;
 *  the rest of its dt is dropped and counted in ::ef_drive_t::late_us). */
#ifndef EF_DRIVE_MAX_STEPS
#define EF_DRIVE_MAX_STEPS 64
#endif

/** Shortest feed-hold or resume ramp (us): a slow axis still gets a gentle one. */
#ifndef EF_DRIVE_HOLD_RAMP_MIN_US
#define EF_DRIVE_HOLD_RAMP_MIN_US 50000u
#endif

/** Drive states. */
typedef enum {
    EF_DRV_DISABLED = 0, /**< power stage off */
    EF_DRV_ENABLED = 1,  /**< holding position, not executing */
    EF_DRV_RUNNING = 2,  /**< executing the queue (or waiting at rest for more) */
    EF_DRV_STOPPING = 3, /**< controlled deceleration (quick stop or fault) */
    EF_DRV_FAULT = 4,    /**< stopped after a fault; needs a fault reset */
} ef_drive_state_t;

/** Fault codes (::ef_drive_t::fault). */
typedef enum {
    EF_DRV_FAULT_NONE = 0,
    EF_DRV_FAULT_UNDERRUN = 1,  /**< queue ran dry while moving */
    EF_DRV_FAULT_FOLLOWING = 2, /**< following error above the limit */
    EF_DRV_FAULT_WATCHDOG = 3,  /**< the master went silent while running (transport) */
    EF_DRV_FAULT_INJECTED = 4,  /**< raised by ef_drive_fault() (tests, external input) */
    EF_DRV_FAULT_SEGMENT = 5,   /**< a queued segment was refused by the interpolator */
    EF_DRV_FAULT_STO = 6,       /**< the hardware enable (safe torque off) input dropped while
                                     the power stage was on (raised by the drive's I/O) */
} ef_drive_fault_t;

/** The largest ::ef_drive_fault_t. */
#define EF_DRV_FAULT_LAST EF_DRV_FAULT_STO

/** Servo model and stop parameters, per axis (all axes alike). */
typedef struct {
    float wn;       /**< position loop natural frequency (rad/s), > 0; wn * period <= 0.5 */
    float zeta;     /**< damping ratio, > 0 */
    float v_lim;    /**< axis speed limit (units/s), > 0 */
    float a_lim;    /**< axis acceleration limit (units/s^2), > 0 */
    float ferr_lim; /**< following error that faults (units), > 0 */
    float a_stop;   /**< path deceleration of a controlled stop (units/s^2), > 0 */
} ef_servo_cfg_t;

/** Defaults: wn 2*pi*40 rad/s, zeta 1, 500 units/s, 20000 units/s^2, 1 unit, 2000 units/s^2. */
void ef_servo_cfg_default(ef_servo_cfg_t *c);

/** Drive state (public for static allocation; treat as private, read with the getters or
 *  the documented fields). */
typedef struct {
    ef_servo_cfg_t cfg;
    uint32_t period_us;
    ef_move_t ring[EF_DRIVE_SLOTS];
    uint32_t ring_head, ring_count;
    ef_interp_t ip;
    uint8_t state;     /**< ::ef_drive_state_t */
    uint8_t fault;     /**< ::ef_drive_fault_t, sticky until reset */
    uint8_t direct;    /**< direct mode (target positions) */
    uint8_t pad;       /**< private: the state a controlled stop ends in */
    uint32_t next_seq; /**< sequence number expected next */
    uint32_t done_seq; /**< last segment completed (valid when done_any) */
    uint32_t done_any; /**< segments completed since the clear */
    uint32_t exec_seq; /**< segment executing now (valid while moving) */
    ef_vec3_t cmd;     /**< commanded position */
    ef_vec3_t cmd_vel; /**< commanded velocity (units/s) */
    ef_vec3_t act;     /**< actual position (servo model) */
    ef_vec3_t act_vel; /**< actual velocity */
    ef_vec3_t target;  /**< direct mode target */
    float ferr;        /**< following error now, |cmd - act| */
    float ferr_max;    /**< largest since the clear */
    uint32_t acc_us;   /**< time not yet stepped (< period) */
    uint32_t time_ms;  /**< time executed in RUNNING/STOPPING since the clear (ms, wraps) */
    uint32_t time_us;  /**< sub-millisecond part of time_ms */
    uint32_t late_us;  /**< time dropped by late calls (see ::EF_DRIVE_MAX_STEPS) */
    float rate;        /**< feed rate now, 0..1 (a feed hold ramps it down and back) */
    float rate0;       /**< private: where the rate's ramp began */
    float rate1;       /**< private: where it ends (0 hold, 1 resume) */
    float ramp_u;      /**< private: the ramp's phase, 0..1 (1: done) */
    float ramp_k;      /**< private: phase per servo period */
    float v_law;       /**< private: the law's speed at the last setpoint (at rate 1) */
    uint8_t moving;    /**< the interpolator is executing a segment */
    uint8_t hold;      /**< feed hold requested (ef_drive_hold) */
    uint8_t held;      /**< feed hold complete: requested and the rate is 0 */
} ef_drive_t;

/**
 * @brief Initialise DISABLED at rest at home, queue empty, next sequence number 0.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, period 0, or a servo parameter not positive and finite
 *                          (or wn * period > 0.5, where the discrete loop misbehaves)
 * @retval EF_ERR_NONFINITE home not finite
 */
int ef_drive_init(ef_drive_t *d, const ef_servo_cfg_t *cfg, ef_vec3_t home, uint32_t period_us);

/**
 * @brief Enable (on != 0) or disable the power stage.
 * Disabling while RUNNING or STOPPING first stops (controlled); the drive becomes DISABLED
 * when at rest. Enabling sets the command to the actual position.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE enable in FAULT (reset the fault first)
 */
int ef_drive_enable(ef_drive_t *d, int on);

/**
 * @brief Start executing the queue (ENABLED -> RUNNING); no effect when already RUNNING.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE not ENABLED or RUNNING (disabled, stopping, fault), or direct mode
 */
int ef_drive_start(ef_drive_t *d);

/**
 * @brief Controlled stop: RUNNING -> STOPPING -> ENABLED. The queue is flushed (the
 * remaining segments are not executed); next_seq is kept so late retries stay duplicates.
 * No effect when not RUNNING.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_drive_quick_stop(ef_drive_t *d);

/**
 * @brief Raise a fault: a controlled stop if moving, then FAULT. The first fault's code is
 * kept until reset.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL or code not a ::ef_drive_fault_t other than NONE
 */
int ef_drive_fault(ef_drive_t *d, int code);

/**
 * @brief Reset a fault: FAULT -> DISABLED, queue cleared, sequence numbers from 0.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE not in FAULT, or still STOPPING
 */
int ef_drive_fault_reset(ef_drive_t *d);

/**
 * @brief Clear the queue and the counters; the next sequence number is 0 again.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE RUNNING while moving, or STOPPING
 */
int ef_drive_clear(ef_drive_t *d);

/**
 * @brief Select direct mode (on != 0: target positions) or segment mode.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE RUNNING or STOPPING
 */
int ef_drive_set_direct(ef_drive_t *d, int on);

/**
 * @brief Direct mode: the new target position.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL
 * @retval EF_ERR_NONFINITE p not finite
 * @retval EF_ERR_STATE     not in direct mode, or not ENABLED/RUNNING
 */
int ef_drive_set_target(ef_drive_t *d, ef_vec3_t p);

/**
 * @brief Queue a segment (checked: the interpolator's checks, degree, finite data).
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL, or a segment the interpolator would refuse (bad degree,
 *                      duration, non-finite data, or not starting where the previous one
 *                      ends; nothing queued)
 * @retval EF_ERR_DUP   seq below the expected one: already accepted, not queued again
 * @retval EF_ERR_SEQ   seq above the expected one (a gap)
 * @retval EF_ERR_FULL  ring full
 * @retval EF_ERR_STATE DISABLED, STOPPING or FAULT, or direct mode
 */
int ef_drive_push(ef_drive_t *d, const ef_move_t *m);

/**
 * @brief Feed hold (on != 0) or resume (0): ramp the segments' time rate to 0 or back to 1
 * (see the file comment). A request equal to the present one changes nothing; a new one
 * during a ramp starts a new ramp from the rate reached. Kept across stops and clears (the
 * master's level); in direct mode the master's targets are the path, so a hold is refused.
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_STATE on != 0 in direct mode
 */
int ef_drive_hold(ef_drive_t *d, int on);

/** @brief Free ring places (0 for NULL). */
uint32_t ef_drive_free(const ef_drive_t *d);

/**
 * @brief Advance time by dt_us: step the interpolator (or the direct profile / stop
 * ramp) and the servo model once per elapsed period.
 * @param next_us out (may be NULL): microseconds until the next period is due
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL d
 * @retval EF_ERR_DRIVE a fault was raised during this call (::ef_drive_t::fault says
 *                      which; the controlled stop has begun)
 */
int ef_drive_process(ef_drive_t *d, uint32_t dt_us, uint32_t *next_us);

#ifdef __cplusplus
}
#endif

#endif /* EF_DRIVE_H */
