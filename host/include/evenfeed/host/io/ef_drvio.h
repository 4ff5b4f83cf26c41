/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_drvio.h
 * @brief A simulated drive's own machine I/O (evenfeed sim-drive --sto, --alarm-out): the
 * hardware enable input (safe torque off) and the alarm output, on ef_gpio.h lines.
 *
 * What a servo drive wires besides its bus: an STO / enable input the controller's enable
 * output (or the safety relay behind it) drives, and an alarm output the controller reads as
 * a drive alarm. Here:
 * - **STO input** (logical 1 = torque permitted; `active = low` as for any line): while it
 *   reads 0 the drive may not have its power stage on. The drive raises
 *   ::EF_DRV_FAULT_STO when it is, or gets there (EMCY 0xFF06 on CAN, fault 6 on Modbus).
 *   A GPIO read error counts as 0: a drive that cannot see its enable input must not run.
 *   The simulation stops along its stop ramp; a real drive's STO removes torque at once
 *   (the axis coasts or its brake holds), which is why the controller's e-stop commands a
 *   controlled stop first and drops enable only at rest (docs/io.md).
 * - **alarm output** (logical 1 = alarm): 1 while the drive is in fault (or stopping into
 *   one), 0 otherwise. Its safe state is 1: a drive process that ends signals alarm.
 *
 * Lines are given as CHIP:LINE (chip as ef_gpio.h takes it, line by name or offset), or a
 * line name alone on gpiochip0. Each is optional. Non-blocking: ef_drvio_process() at every
 * step of the drive (the debounce is ef_gpio's, 2 ms).
 */
#ifndef EF_DRVIO_H
#define EF_DRVIO_H

#include <stdint.h>
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/io/ef_gpio.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Input debounce (us). */
#define EF_DRVIO_DEBOUNCE_US 2000u

/** Drive I/O state. */
typedef struct {
    ef_gpio_t g;
    int sto;   /**< index of the STO input in g (-1: none) */
    int alarm; /**< index of the alarm output in g (-1: none) */
    int open;
    uint8_t alarm_on;   /**< the alarm output's value now */
    uint64_t sto_drops; /**< times the STO input was seen at 0 while the drive ran */
} ef_drvio_t;

/**
 * @brief Request the lines (either may be NULL or ""; both NULL: nothing opened, io->open 0).
 * The alarm output starts active (its safe state) until the first ef_drvio_process().
 * @retval EF_OK
 * @retval EF_ERR_ARG a spec too long or with an empty chip or line
 * @retval EF_ERR_IO  as ef_gpio_open(): no such chip or line, held by another consumer,
 *         the kernel refused (an output on an input-only line)
 */
int ef_drvio_open(ef_drvio_t *io, const char *sto, const char *alarm, ef_msg_t *m);

/**
 * @brief Read the STO input and set the alarm output to `fault`.
 * @return 1 torque permitted (input 1, or no input wired), 0 not (input 0 or unreadable:
 *         m says which when a read failed)
 */
int ef_drvio_process(ef_drvio_t *io, int fault, ef_msg_t *m);

/** @brief Alarm output to its safe state (active), lines released. */
void ef_drvio_close(ef_drvio_t *io);

#ifdef __cplusplus
}
#endif

#endif /* EF_DRVIO_H */
