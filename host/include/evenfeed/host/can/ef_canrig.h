/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canrig.h
 * @brief A CANopen master and drives on the in-memory bus (ef_canmem.h), each on its own
 * transport port and its own pump (ef_canpump.h), stepped together in simulated time.
 *
 * The bus-load benchmark, `evenfeed demo` (ef_canload.h) and the master's integration tests
 * run the production objects through the production pump this way; only the transport
 * differs from `evenfeed stream --can` / `sim-drive can`. One step of dt_us: the bus's time
 * advances, the master's pump runs (frames it received, then its time, then its sends), the
 * bus carries what its bit rate allows, every drive's pump runs, the bus carries again. So a
 * frame reaches a drive in the step it was sent (bit rate permitting) and the drive's
 * answer reaches the master at the start of the next step, before the master's time does.
 *
 * The master and drives are the caller's objects (any storage); the rig holds the bus (about
 * 80 KB with the default queue sizes: make it static or allocate it).
 */
#ifndef EF_CANRIG_H
#define EF_CANRIG_H

#include <stdint.h>

#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/host/can/ef_canmem.h"
#include "evenfeed/host/can/ef_canpump.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most drives on one rig: every port of the bus but the master's. */
#define EF_CANRIG_MAX_DRIVES (EF_CANMEM_MAX_PORTS - 1)

/** A rig (fields readable: bus statistics and time are in `bus`). */
typedef struct {
    ef_canmem_t bus;
    ef_canif_t ci[EF_CANMEM_MAX_PORTS];
    ef_canpump_t pump[EF_CANMEM_MAX_PORTS];
    ef_comaster_t *m; /**< NULL until ef_canrig_add_master() */
    ef_codrive_t *d[EF_CANRIG_MAX_DRIVES];
    int n_drives;
    int hold_master;      /**< nonzero: steps leave the master's pump out (a starved master:
                               frames queue at its port, its next poll sees the whole gap) */
    uint32_t hold_drives; /**< bit k-1 set: drive k's pump is left out (a dead node) */
} ef_canrig_t;

/** @brief An empty rig on a bus of `bitrate` bits/s (0: infinitely fast), time 0. */
void ef_canrig_init(ef_canrig_t *g, uint32_t bitrate);

/**
 * @brief Open port 0 for the master and initialise it there (ef_comaster_init()).
 * @retval EF_OK
 * @retval EF_ERR_STATE a master was added already
 * @retval (other) ef_comaster_init()'s or the port's error
 */
int ef_canrig_add_master(ef_canrig_t *g, ef_comaster_t *m, const ef_com_cfg_t *c);

/**
 * @brief Open the next port for a drive and initialise it there (ef_codrive_init()).
 * @retval EF_OK
 * @retval EF_ERR_FULL ::EF_CANRIG_MAX_DRIVES drives already
 * @retval (other) ef_codrive_init()'s or the port's error
 */
int ef_canrig_add_drive(ef_canrig_t *g, ef_codrive_t *d, const ef_codrive_cfg_t *c);

/** @brief One step of dt_us (order in the file comment). */
void ef_canrig_step(ef_canrig_t *g, uint32_t dt_us);

/** @brief Steps of step_us until `us` have passed. */
void ef_canrig_run(ef_canrig_t *g, uint32_t us, uint32_t step_us);

/** @brief Steps of step_us until the master is in state `st`, DONE or ERROR, at most max_us;
 *  the master's state then (EF_COM_IDLE without a master). */
int ef_canrig_run_until(ef_canrig_t *g, int st, uint32_t max_us, uint32_t step_us);

/** @brief Close every open port (the objects stay the caller's). */
void ef_canrig_close(ef_canrig_t *g);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANRIG_H */
