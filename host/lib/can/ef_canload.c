/* SPDX-License-Identifier: Apache-2.0 */
/* A path streamed by the CANopen master to three drives on a simulated bus, bits counted
 * (see ef_canload.h). */
#include "evenfeed/host/can/ef_canload.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/can/ef_canrig.h"

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

/* Everything one run needs, allocated together (the bus alone is large). */
typedef struct {
    ef_canrig_t rig;
    ef_comaster_t ms;
    ef_codrive_t d[3];
} cl_rig_t;

/* Set the master and the drives (homed at the path's start) up on the rig. */
static int cl_setup(cl_rig_t *g, const ef_canload_path_t *p, const ef_com_cfg_t *mc, ef_msg_t *m)
{
    int rc = ef_canrig_add_master(&g->rig, &g->ms, mc);
    for (int k = 0; k < 3 && rc == EF_OK; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = (float)p->start[k];
        rc = ef_canrig_add_drive(&g->rig, &g->d[k], &dc);
    }
    if (rc != EF_OK)
        return ef_fail(m, rc, "canload: set-up refused (%d)", rc);
    return EF_OK;
}

/* Close the ports and free the rig. */
static void cl_free(cl_rig_t *g)
{
    ef_canrig_close(&g->rig);
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
    ef_canrig_init(&g->rig, bitrate);
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
    if (ef_canrig_run_until(&g->rig, EF_COM_RUN, 10000000u, CL_STEP_US) != EF_COM_RUN) {
        rc = cl_fail(g, &mc, m, "bring-up");
        cl_free(g);
        return rc;
    }
    uint64_t t0 = g->rig.bus.now_us, b0 = g->rig.bus.bits, f0 = g->rig.bus.frames, bits0[16],
             frames0[16];
    memcpy(bits0, g->rig.bus.bits_fn, sizeof bits0);
    memcpy(frames0, g->rig.bus.frames_fn, sizeof frames0);
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
        ef_canrig_step(&g->rig, CL_STEP_US);
        steps++;
    }
    if (ef_comaster_state(&g->ms) == EF_COM_RUN)
        (void)ef_comaster_finish(&g->ms);
    r->state = ef_canrig_run_until(&g->rig, EF_COM_DONE, 60000000u, CL_STEP_US);
    r->seconds = (double)(g->rig.bus.now_us - t0) * 1e-6;
    r->bits = (double)(g->rig.bus.bits - b0);
    r->frames = (double)(g->rig.bus.frames - f0);
    for (int i = 0; i < 16; i++) {
        r->bits_fn[i] = (double)(g->rig.bus.bits_fn[i] - bits0[i]);
        r->frames_fn[i] = (double)(g->rig.bus.frames_fn[i] - frames0[i]);
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
