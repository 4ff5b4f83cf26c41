/* SPDX-License-Identifier: Apache-2.0 */
/* A path streamed by the CANopen master to three drives on a simulated bus, bits counted
 * (see ef_canload.h). */
#include "evenfeed/host/can/ef_canload.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/can/ef_canmem.h"
#include "evenfeed/host/can/ef_canpump.h"

/** Simulated time step (us): a tenth of the fastest cycle. */
#define CL_STEP_US 100u

/* Keep every move. */
static int cl_on_move(void *user, const ef_move_t *mv, const ef_pipe_move_info_t *mi)
{
    (void)mi;
    ef_canload_path_t *p = user;
    if (p->nmv == p->cap_mv) {
        size_t cap = p->cap_mv ? 2 * p->cap_mv : 512;
        ef_move_t *n = realloc(p->mv, cap * sizeof *n);
        if (!n)
            return EF_ERR_NOMEM;
        p->mv = n;
        p->cap_mv = cap;
    }
    p->mv[p->nmv++] = *mv;
    return 0;
}

/* Keep every setpoint (the CSP targets). */
static int cl_on_sp(void *user, double t, const ef_setpoint_t *sp, const ef_pipe_move_info_t *mi)
{
    (void)t;
    (void)mi;
    ef_canload_path_t *p = user;
    if (p->nsp == p->cap_sp) {
        size_t cap = p->cap_sp ? 2 * p->cap_sp : 16384;
        float *n = realloc(p->sp, cap * 3 * sizeof *n);
        if (!n)
            return EF_ERR_NOMEM;
        p->sp = n;
        p->cap_sp = cap;
    }
    p->sp[3 * p->nsp] = sp->p.x;
    p->sp[3 * p->nsp + 1] = sp->p.y;
    p->sp[3 * p->nsp + 2] = sp->p.z;
    p->nsp++;
    return 0;
}

/* Smooth and keep moves and setpoints (contract in ef_canload.h). */
int ef_canload_path(ef_gcode_t *r, const ef_pipe_cfg_t *pc, ef_canload_path_t *p, ef_msg_t *m)
{
    if (!r || !pc || !p)
        return ef_fail(m, EF_ERR_ARG, "canload: NULL argument");
    memset(p, 0, sizeof *p);
    ef_pipe_cfg_t c = *pc;
    c.interp_modes |= 1u << c.step_mode;
    ef_pipe_cb_t cb;
    memset(&cb, 0, sizeof cb);
    cb.on_move = cl_on_move;
    cb.on_setpoint = cl_on_sp;
    cb.user = p;
    ef_pipe_stats_t st;
    int rc = ef_pipe_run(r, &c, &cb, &st, m);
    if (rc != EF_OK) {
        ef_canload_path_free(p);
        return rc;
    }
    memcpy(p->start, st.start, sizeof p->start);
    memcpy(p->end, st.end, sizeof p->end);
    p->duration = st.cycle_time;
    p->period_us = c.period_us;
    return EF_OK;
}

/* Free the path's arrays. */
void ef_canload_path_free(ef_canload_path_t *p)
{
    if (!p)
        return;
    free(p->mv);
    free(p->sp);
    memset(p, 0, sizeof *p);
}

/* Everything one run needs, allocated together (the bus alone is large): the bus, the
 * master on port 0 and the drives on ports 1..3, each run by its own pump, as
 * `evenfeed stream --can` and `evenfeed sim-drive can` run them on SocketCAN. */
typedef struct {
    ef_canmem_t bus;
    ef_canif_t ci[4];
    ef_canpump_t pump[4];
    ef_comaster_t ms;
    ef_codrive_t d[3];
} cl_rig_t;

/* One simulated step: time passes, the master's pump runs, the bus carries what it can,
 * then the drives' pumps, and the bus again (so a frame the master sends reaches the
 * drives in the same step, and their answers the master at its next). */
static void cl_step(cl_rig_t *g)
{
    ef_canmem_advance(&g->bus, CL_STEP_US);
    (void)ef_canpump_poll(&g->pump[0], 0); /* the in-memory bus has no I/O errors */
    ef_canmem_deliver(&g->bus);
    for (int k = 1; k < 4; k++)
        (void)ef_canpump_poll(&g->pump[k], 0);
    ef_canmem_deliver(&g->bus);
}

/* Step until the master is in state st (or DONE / ERROR), at most max_us; its state. */
static int cl_run_until(cl_rig_t *g, int st, uint32_t max_us)
{
    for (uint32_t t = 0; t < max_us; t += CL_STEP_US) {
        int s = ef_comaster_state(&g->ms);
        if (s == st || s == EF_COM_DONE || s == EF_COM_ERROR)
            return s;
        cl_step(g);
    }
    return ef_comaster_state(&g->ms);
}

/* Open the four ports and set the master and the drives up on them. */
static int cl_setup(cl_rig_t *g, const ef_canload_path_t *p, const ef_com_cfg_t *mc, ef_msg_t *m)
{
    static const char *names[4] = {"master", "drive1", "drive2", "drive3"};
    for (int k = 0; k < 4; k++) {
        g->ci[k] = ef_canmem_canif(&g->bus, k);
        ef_canif_cfg_t ic = {.name = names[k]};
        int rc = ef_canif_open(&g->ci[k], &ic, m);
        if (rc != EF_OK)
            return rc;
    }
    ef_canpump_node_t node = ef_canpump_master_node(&g->ms);
    int rc = ef_canpump_init(&g->pump[0], &g->ci[0], &node, NULL);
    ef_can_port_t port = ef_canif_port(&g->ci[0]);
    if (rc == EF_OK)
        rc = ef_comaster_init(&g->ms, mc, &port);
    for (int k = 0; k < 3 && rc == EF_OK; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = (float)p->start[k];
        node = ef_canpump_drive_node(&g->d[k]);
        rc = ef_canpump_init(&g->pump[k + 1], &g->ci[k + 1], &node, NULL);
        port = ef_canif_port(&g->ci[k + 1]);
        if (rc == EF_OK)
            rc = ef_codrive_init(&g->d[k], &dc, &port);
    }
    if (rc != EF_OK)
        return ef_fail(m, rc, "canload: set-up refused (%d)", rc);
    return EF_OK;
}

/* Close the ports and free the rig. */
static void cl_free(cl_rig_t *g)
{
    for (int k = 0; k < 4; k++)
        ef_canif_close(&g->ci[k]);
    free(g);
}

/* The master's error as a message. */
static int cl_fail(cl_rig_t *g, ef_com_cfg_t *mc, ef_msg_t *m, const char *when)
{
    const ef_com_error_t *e = ef_comaster_error(&g->ms);
    char text[256];
    ef_can_error_text(e, mc, "simulated bus", text, sizeof text);
    return ef_fail(m, e->code ? e->code : EF_ERR_TIMEOUT, "canload: %s: %s (master state %d)", when,
                   e->code ? text : "no error, but not finished", ef_comaster_state(&g->ms));
}

/* Stream the path in one mode and count (contract in ef_canload.h). */
int ef_canload_run(const ef_canload_path_t *p, int mode, uint32_t bitrate, ef_canload_result_t *r,
                   ef_msg_t *m)
{
    if (!p || !r || (mode != EF_COM_MODE_CSP && mode != EF_COM_MODE_SEGMENT))
        return ef_fail(m, EF_ERR_ARG, "canload: bad argument");
    size_t total = mode == EF_COM_MODE_CSP ? p->nsp : p->nmv;
    if (total == 0)
        return ef_fail(m, EF_ERR_ARG, "canload: empty path");
    memset(r, 0, sizeof *r);
    cl_rig_t *g = calloc(1, sizeof *g);
    if (!g)
        return ef_fail(m, EF_ERR_NOMEM, "canload: out of memory");
    ef_canmem_init(&g->bus, bitrate);
    ef_com_cfg_t mc;
    ef_comaster_cfg_default(&mc, mode);
    mc.n_nodes = 3;
    for (int k = 0; k < 3; k++)
        mc.nodes[k] = (uint8_t)(k + 1);
    if (mode == EF_COM_MODE_CSP)
        mc.cycle_us = p->period_us;
    int rc = cl_setup(g, p, &mc, m);
    if (rc != EF_OK) {
        cl_free(g);
        return rc;
    }
    if (cl_run_until(g, EF_COM_RUN, 10000000u) != EF_COM_RUN) {
        rc = cl_fail(g, &mc, m, "bring-up");
        cl_free(g);
        return rc;
    }
    uint64_t t0 = g->bus.now_us, b0 = g->bus.bits, f0 = g->bus.frames, bits0[16], frames0[16];
    memcpy(bits0, g->bus.bits_fn, sizeof bits0);
    memcpy(frames0, g->bus.frames_fn, sizeof frames0);
    size_t next = 0;
    /* Bounded: the path's time plus a margin, in simulated steps. */
    uint64_t steps = 0, max_steps = (uint64_t)(p->duration * 1e6 / CL_STEP_US) * 4u + 1000000u;
    while (next < total && ef_comaster_state(&g->ms) == EF_COM_RUN && steps < max_steps) {
        if (mode == EF_COM_MODE_CSP)
            rc = ef_comaster_push_target(&g->ms, p->sp + 3 * next);
        else
            rc = ef_comaster_push_move(&g->ms, &p->mv[next]);
        if (rc == EF_OK) {
            next++;
            continue;
        }
        if (rc != EF_ERR_FULL)
            break;
        cl_step(g);
        steps++;
    }
    if (ef_comaster_state(&g->ms) == EF_COM_RUN)
        (void)ef_comaster_finish(&g->ms);
    r->state = cl_run_until(g, EF_COM_DONE, 60000000u);
    r->seconds = (double)(g->bus.now_us - t0) * 1e-6;
    r->bits = (double)(g->bus.bits - b0);
    r->frames = (double)(g->bus.frames - f0);
    for (int i = 0; i < 16; i++) {
        r->bits_fn[i] = (double)(g->bus.bits_fn[i] - bits0[i]);
        r->frames_fn[i] = (double)(g->bus.frames_fn[i] - frames0[i]);
    }
    double e2 = 0;
    for (int k = 0; k < 3; k++) {
        double d = ef_codrive_position(&g->d[k]) - p->end[k];
        e2 += d * d;
        r->ferr_max = fmax(r->ferr_max, g->d[k].drv.ferr_max);
        r->executed[k] = g->d[k].drv.done_any;
        r->resends += ef_comaster_node(&g->ms, k)->resends;
    }
    r->end_err = sqrt(e2);
    r->starved = g->ms.starved;
    r->err = *ef_comaster_error(&g->ms);
    rc = EF_OK;
    if (next < total || r->state != EF_COM_DONE)
        rc = cl_fail(g, &mc, m, next < total ? "streaming" : "finishing");
    cl_free(g);
    return rc;
}

/* What each function code carries in evenfeed's PDO layouts (docs/can.md). */
const char *ef_canload_fn_name(int fn)
{
    switch (fn) {
    case 0x0:
        return "NMT";
    case 0x1:
        return "SYNC + EMCY";
    case 0x3:
        return "TPDO1 (status, position, flow)";
    case 0x4:
        return "RPDO1 (controlword, target)";
    case 0x5:
        return "law records (0x280)";
    case 0x6:
        return "RPDO2 (axis records)";
    case 0xB:
        return "SDO server -> client";
    case 0xC:
        return "SDO client -> server";
    case 0xE:
        return "heartbeat";
    default:
        return "other";
    }
}
