/* SPDX-License-Identifier: Apache-2.0 */
/* A master and drives on the in-memory bus, one pump each, in simulated time (ef_canrig.h). */
#include "evenfeed/host/can/ef_canrig.h"

#include <stdio.h>
#include <string.h>

void ef_canrig_init(ef_canrig_t *g, uint32_t bitrate)
{
    memset(g, 0, sizeof *g);
    ef_canmem_init(&g->bus, bitrate);
}

/* Open port k under a name that says who is on it (messages, candump log). */
static int crig_open(ef_canrig_t *g, int k, ef_msg_t *m)
{
    char name[24]; /* "drive" and a port number */
    if (k == 0)
        snprintf(name, sizeof name, "master");
    else
        snprintf(name, sizeof name, "drive%d", k);
    g->ci[k] = ef_canmem_canif(&g->bus, k);
    ef_canif_cfg_t ic = {.name = name};
    return ef_canif_open(&g->ci[k], &ic, m);
}

int ef_canrig_add_master(ef_canrig_t *g, ef_comaster_t *m, const ef_com_cfg_t *c)
{
    if (g->m)
        return EF_ERR_STATE;
    ef_msg_t msg;
    int rc = crig_open(g, 0, &msg);
    ef_canpump_node_t node = ef_canpump_master_node(m);
    if (rc == EF_OK)
        rc = ef_canpump_init(&g->pump[0], &g->ci[0], &node, NULL);
    ef_can_port_t port = ef_canif_port(&g->ci[0]);
    if (rc == EF_OK)
        rc = ef_comaster_init(m, c, &port);
    if (rc == EF_OK)
        g->m = m;
    return rc;
}

int ef_canrig_add_drive(ef_canrig_t *g, ef_codrive_t *d, const ef_codrive_cfg_t *c)
{
    if (g->n_drives >= EF_CANRIG_MAX_DRIVES)
        return EF_ERR_FULL;
    int k = g->n_drives + 1;
    ef_msg_t msg;
    int rc = crig_open(g, k, &msg);
    ef_canpump_node_t node = ef_canpump_drive_node(d);
    if (rc == EF_OK)
        rc = ef_canpump_init(&g->pump[k], &g->ci[k], &node, NULL);
    ef_can_port_t port = ef_canif_port(&g->ci[k]);
    if (rc == EF_OK)
        rc = ef_codrive_init(d, c, &port);
    if (rc == EF_OK)
        g->d[g->n_drives++] = d;
    return rc;
}

void ef_canrig_step(ef_canrig_t *g, uint32_t dt_us)
{
    ef_canmem_advance(&g->bus, dt_us);
    if (g->m && !g->hold_master)
        (void)ef_canpump_poll(&g->pump[0], 0); /* the in-memory bus has no I/O errors */
    ef_canmem_deliver(&g->bus);
    for (int k = 1; k <= g->n_drives; k++)
        if (!(g->hold_drives & (1u << (k - 1))))
            (void)ef_canpump_poll(&g->pump[k], 0);
    ef_canmem_deliver(&g->bus);
}

void ef_canrig_run(ef_canrig_t *g, uint32_t us, uint32_t step_us)
{
    for (uint32_t t = 0; t < us; t += step_us)
        ef_canrig_step(g, step_us);
}

int ef_canrig_run_until(ef_canrig_t *g, int st, uint32_t max_us, uint32_t step_us)
{
    if (!g->m)
        return EF_COM_IDLE;
    for (uint32_t t = 0; t < max_us; t += step_us) {
        int s = ef_comaster_state(g->m);
        if (s == st || s == EF_COM_DONE || s == EF_COM_ERROR)
            return s;
        ef_canrig_step(g, step_us);
    }
    return ef_comaster_state(g->m);
}

void ef_canrig_close(ef_canrig_t *g)
{
    for (int k = 0; k < EF_CANMEM_MAX_PORTS; k++)
        if (g->ci[k].ops)
            ef_canif_close(&g->ci[k]);
}
