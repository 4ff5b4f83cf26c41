/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canload.h
 * @brief A smoothed path streamed by the real CANopen master (ef_comaster.h) to real drives
 * (ef_codrive.h), one per axis, over an in-memory bus in simulated time, with every frame's
 * bits counted: the bus-load benchmark (tests/bench/bench_canbus.c) and the CAN part of
 * `evenfeed demo`, on any machine (no CAN kernel needed; the hardware-in-loop tests run the
 * same code over SocketCAN).
 *
 * Errors: EF_ERR_* codes plus a message (host convention).
 */
#ifndef EF_CANLOAD_H
#define EF_CANLOAD_H

#include <stddef.h>
#include <stdint.h>

#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/program/ef_pipeline.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A path as both modes need it: the moves (segment mode) and the setpoints at the CSP
 *  cycle (CSP targets). */
typedef struct {
    ef_move_t *mv;
    size_t nmv;
    float *sp; /**< 3 floats per setpoint */
    size_t nsp;
    uint32_t period_us; /**< setpoint period (the CSP cycle) */
    double start[3], end[3];
    double duration; /**< sum of the move durations (s) */
    size_t cap_mv, cap_sp;
} ef_canload_path_t;

/**
 * @brief Smooth a program (pc: tables, limits; its interpolator is run at pc->period_us in
 * pc->step_mode) and keep its moves and setpoints.
 * @retval EF_OK
 * @retval EF_ERR_NOMEM out of memory
 * @retval other        the pipeline's error (G-code, smoothing)
 */
int ef_canload_path(ef_gcode_t *r, const ef_pipe_cfg_t *pc, ef_canload_path_t *p, ef_msg_t *m);

/** @brief Free what ef_canload_path() allocated (NULL or empty is harmless). */
void ef_canload_path_free(ef_canload_path_t *p);

/** Figures of one run, from RUN (bring-up excluded) until every drive is at rest. */
typedef struct {
    double seconds;                    /**< simulated time counted */
    double bits, frames;               /**< on the bus, both directions, worst-case stuffing */
    double bits_fn[16], frames_fn[16]; /**< by function code (identifier >> 7) */
    double end_err;       /**< distance of the drives' final position from the path's end */
    double ferr_max;      /**< largest following error of any drive (units) */
    uint32_t executed[3]; /**< segment mode: segments each drive completed */
    uint32_t resends;     /**< go-back-N rounds */
    uint32_t starved;     /**< CSP: cycles without a target */
    int state;            /**< the master's final ::ef_com_state_t */
    ef_com_error_t err;   /**< the master's first error */
} ef_canload_result_t;

/**
 * @brief Stream p in a mode (::ef_com_mode_t) to three drives (nodes 1, 2, 3 at the path's
 * start) at `bitrate` bits/s (0: an infinitely fast bus), CSP cycle p->period_us.
 * @retval EF_OK        every move (target) executed and the master DONE
 * @retval EF_ERR_ARG   NULL, an empty path, unknown mode
 * @retval EF_ERR_NOMEM out of memory
 * @retval other        the master's error (bring-up or streaming), named in the message
 */
int ef_canload_run(const ef_canload_path_t *p, int mode, uint32_t bitrate, ef_canload_result_t *r,
                   ef_msg_t *m);

/** @brief What a function code (identifier >> 7) carries in evenfeed's layouts. */
const char *ef_canload_fn_name(int fn);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANLOAD_H */
