/* SPDX-License-Identifier: Apache-2.0 */
/* A simulated drive's STO input and alarm output (see ef_drvio.h). */
#include <string.h>
#include <time.h>
#include "evenfeed/host/io/ef_drvio.h"

/* CHIP:LINE, or LINE on gpiochip0, into a line's configuration. */
static int drvio_spec(ef_gpio_line_cfg_t *l, const char *spec, ef_msg_t *m)
{
    if (ef_gpio_spec(l, spec, "gpiochip0") != EF_GPIO_SPEC_OK)
        return ef_fail(m, EF_ERR_ARG, "sim-drive: line '%s': want CHIP:LINE or LINE", spec);
    return EF_OK;
}

int ef_drvio_open(ef_drvio_t *io, const char *sto, const char *alarm, ef_msg_t *m)
{
    memset(io, 0, sizeof *io);
    io->sto = io->alarm = -1;
    ef_gpio_line_cfg_t cfg[2];
    memset(cfg, 0, sizeof cfg);
    unsigned n = 0;
    int rc;
    if (sto && sto[0]) {
        if ((rc = drvio_spec(&cfg[n], sto, m)) != EF_OK)
            return rc;
        cfg[n].what = "sto";
        cfg[n].dir = EF_GPIO_IN;
        cfg[n].debounce_us = EF_DRVIO_DEBOUNCE_US;
        io->sto = (int)n++;
    }
    if (alarm && alarm[0]) {
        if ((rc = drvio_spec(&cfg[n], alarm, m)) != EF_OK)
            return rc;
        cfg[n].what = "alarm-out";
        cfg[n].dir = EF_GPIO_OUT;
        cfg[n].safe = 1; /* a drive that is gone signals alarm */
        io->alarm = (int)n++;
    }
    if (n == 0)
        return EF_OK;
    if ((rc = ef_gpio_open(&io->g, cfg, n, m)) != EF_OK)
        return rc;
    io->open = 1;
    io->alarm_on = 1;
    return EF_OK;
}

static uint64_t drvio_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

int ef_drvio_process(ef_drvio_t *io, int fault, ef_msg_t *m)
{
    if (!io->open)
        return 1;
    int ok = 1;
    if (io->sto >= 0) {
        uint8_t v = 0;
        ef_gpio_event_t ev;
        /* Events and a sample of the level: the drive steps at least every SYNC, and the
         * sample sees a level that the kernel's merged events do not (ef_gpio.h). */
        uint64_t now = drvio_now_ns();
        if (ef_gpio_process(&io->g, now, NULL, m) < 0 || ef_gpio_sample(&io->g, now, m) < 0)
            ok = 0; /* unreadable: no torque (m says why) */
        while (ef_gpio_next_event(&io->g, &ev) == 1)
            ; /* the level is what counts, not its history */
        if (ok && ef_gpio_get(&io->g, (unsigned)io->sto, &v) != EF_OK)
            ok = 0;
        ok = ok && v;
    }
    uint8_t want = fault != 0;
    if (io->alarm >= 0 && want != io->alarm_on &&
        ef_gpio_set(&io->g, (unsigned)io->alarm, want, NULL) == EF_OK)
        io->alarm_on = want;
    return ok;
}

void ef_drvio_close(ef_drvio_t *io)
{
    if (io->open)
        ef_gpio_close(&io->g); /* the alarm output to its safe state: active */
    io->open = 0;
}
