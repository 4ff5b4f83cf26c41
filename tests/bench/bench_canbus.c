/*
 * CAN bus load, CSP at 1 kHz against evenfeed's segment mode, measured side by side in one
 * run (docs/benchmarks-can.md).
 *
 * The standard path (samples/profile.ngc, smoothed with the streamer's defaults) is streamed
 * to three drives, one per axis, by the real master (ef_comaster) to the real drive code
 * (ef_codrive) over an in-memory bus at 1 Mbit/s (tests/ef_canbus_sim.h) in simulated time:
 * every frame either side sends is counted with its bits on the wire, frame overhead and
 * worst-case bit stuffing included (ef_can_frame_bits()). Counted from the moment the master
 * is in RUN (bring-up is excluded, being the same for both) to the moment all drives are at
 * rest at the program's end; divided by that time, which is the program's own duration plus
 * the start-up of each mode.
 *
 * usage: bench_canbus [program.ngc]    (default samples/profile.ngc from the working dir)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ef_canbus_sim.h"
#include "evenfeed/host/ef_gcode.h"
#include "evenfeed/host/ef_pipeline.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define BC_BITRATE 1000000u
#define BC_STEP_US 100u

typedef struct {
    ef_move_t *mv;
    size_t nmv, capmv;
    float *sp; /* 3 per setpoint, 1 ms apart */
    size_t nsp, capsp;
    double start[3], end[3], duration;
} bc_path_t;

static bc_path_t g_path;

/* Keep every move. */
static int bc_on_move(void *user, const ef_move_t *m, const ef_pipe_move_info_t *mi)
{
    (void)mi;
    bc_path_t *P = user;
    if (P->nmv == P->capmv) {
        P->capmv = P->capmv ? 2 * P->capmv : 512;
        P->mv = realloc(P->mv, P->capmv * sizeof *P->mv);
        if (!P->mv)
            return EF_ERR_NOMEM;
    }
    P->mv[P->nmv++] = *m;
    return 0;
}

/* Keep every setpoint (the CSP targets). */
static int bc_on_sp(void *user, double t, const ef_setpoint_t *sp, const ef_pipe_move_info_t *mi)
{
    (void)t;
    (void)mi;
    bc_path_t *P = user;
    if (P->nsp == P->capsp) {
        P->capsp = P->capsp ? 2 * P->capsp : 16384;
        P->sp = realloc(P->sp, P->capsp * 3 * sizeof *P->sp);
        if (!P->sp)
            return EF_ERR_NOMEM;
    }
    P->sp[3 * P->nsp] = sp->p.x;
    P->sp[3 * P->nsp + 1] = sp->p.y;
    P->sp[3 * P->nsp + 2] = sp->p.z;
    P->nsp++;
    return 0;
}

static ef_sim_bus_t g_bus;
static ef_comaster_t g_m;
static ef_codrive_t g_d[3];

/* Bring up three drives at the path's start in a mode; 0 when RUN. */
static int bc_bringup(int mode)
{
    ef_sim_init(&g_bus);
    g_bus.bitrate = BC_BITRATE;
    ef_com_cfg_t mc;
    ef_comaster_cfg_default(&mc, mode);
    mc.n_nodes = 3;
    for (int k = 0; k < 3; k++)
        mc.nodes[k] = (uint8_t)(k + 1);
    if (ef_sim_add_master(&g_bus, &g_m, &mc) != EF_OK)
        return -1;
    for (int k = 0; k < 3; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = (float)g_path.start[k];
        if (ef_sim_add_drive(&g_bus, &g_d[k], &dc) != EF_OK)
            return -1;
    }
    int st = ef_sim_run_until(&g_bus, EF_COM_RUN, 10000000u, BC_STEP_US);
    if (st != EF_COM_RUN) {
        const ef_com_error_t *e = ef_comaster_error(&g_m);
        fprintf(stderr, "bring-up failed: state %d, error %d (node %u, what %u, 0x%04X:%u)\n", st,
                e->code, e->node, e->what, e->index, e->sub);
        return -1;
    }
    return 0;
}

typedef struct {
    double seconds, bits, frames;
    double bits_fn[16], frames_fn[16];
    double end_err;
    uint32_t resends, starved;
    int ok;
} bc_result_t;

/* Statistics since the last snapshot. */
static void bc_snapshot(uint64_t t0, const uint64_t *bits0, const uint64_t *frames0, uint64_t b0,
                        uint64_t f0, bc_result_t *r)
{
    r->seconds = (double)(g_bus.now_us - t0) * 1e-6;
    r->bits = (double)(g_bus.bits - b0);
    r->frames = (double)(g_bus.frames - f0);
    for (int i = 0; i < 16; i++) {
        r->bits_fn[i] = (double)(g_bus.bits_fn[i] - bits0[i]);
        r->frames_fn[i] = (double)(g_bus.frames_fn[i] - frames0[i]);
    }
}

/* Stream the path in one mode; figures from RUN to DONE. */
static int bc_stream(int mode, bc_result_t *r)
{
    memset(r, 0, sizeof *r);
    if (bc_bringup(mode) != 0)
        return -1;
    uint64_t t0 = g_bus.now_us, b0 = g_bus.bits, f0 = g_bus.frames, bits0[16], frames0[16];
    memcpy(bits0, g_bus.bits_fn, sizeof bits0);
    memcpy(frames0, g_bus.frames_fn, sizeof frames0);
    size_t next = 0, total = mode == EF_COM_MODE_CSP ? g_path.nsp : g_path.nmv;
    uint64_t guard = 0;
    while (next < total && ef_comaster_state(&g_m) == EF_COM_RUN && guard++ < 100000000u) {
        int rc;
        if (mode == EF_COM_MODE_CSP)
            rc = ef_comaster_push_target(&g_m, g_path.sp + 3 * next);
        else
            rc = ef_comaster_push_move(&g_m, &g_path.mv[next]);
        if (rc == EF_OK) {
            next++;
            continue;
        }
        if (rc != EF_ERR_FULL) {
            fprintf(stderr, "push %zu: %d\n", next, rc);
            return -1;
        }
        ef_sim_step(&g_bus, BC_STEP_US);
    }
    if (ef_comaster_finish(&g_m) != EF_OK)
        return -1;
    int st = ef_sim_run_until(&g_bus, EF_COM_DONE, 60000000u, BC_STEP_US);
    bc_snapshot(t0, bits0, frames0, b0, f0, r);
    double e2 = 0;
    for (int k = 0; k < 3; k++) {
        double d = ef_codrive_position(&g_d[k]) - g_path.end[k];
        e2 += d * d;
    }
    r->end_err = sqrt(e2);
    for (int k = 0; k < 3; k++)
        r->resends += ef_comaster_node(&g_m, k)->resends;
    r->starved = g_m.starved;
    r->ok = st == EF_COM_DONE && r->end_err < 1e-3;
    if (!r->ok) {
        const ef_com_error_t *e = ef_comaster_error(&g_m);
        fprintf(stderr, "stream ended in state %d, error %d node %u what %u; end off by %.4f mm\n",
                st, e->code, e->node, e->what, r->end_err);
    }
    return r->ok ? 0 : -1;
}

static const char *bc_fn_name(int fn)
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

static void bc_print(const char *name, const bc_result_t *r)
{
    printf("%s: %.0f frames, %.0f bits in %.3f s: %.1f kbit/s, %.1f %% of 1 Mbit/s"
           " (end within %.2g mm, resends %u, starved cycles %u)\n",
           name, r->frames, r->bits, r->seconds, r->bits / r->seconds * 1e-3,
           r->bits / r->seconds / BC_BITRATE * 100.0, r->end_err, r->resends, r->starved);
    for (int fn = 0; fn < 16; fn++)
        if (r->frames_fn[fn] > 0)
            printf("    %-32s %8.0f frames %10.0f bits  %7.1f kbit/s\n", bc_fn_name(fn),
                   r->frames_fn[fn], r->bits_fn[fn], r->bits_fn[fn] / r->seconds * 1e-3);
}

int main(int argc, char **argv)
{
    const char *prog = argc > 1 ? argv[1] : "samples/profile.ngc";
    ef_gcode_t rd;
    ef_msg_t m = {{0}};
    if (ef_gcode_open(&rd, prog, &m) != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return 2;
    }
    ef_pipe_cfg_t pc;
    ef_pipe_cfg_default(&pc);
    pc.g2 = &ef_tbl_g2_default;
    pc.g1 = &ef_tbl_g1_default;
    pc.period_us = 1000;
    pc.interp_modes = EF_PIPE_INTERP_CORRECTED;
    pc.step_mode = EF_STEP_CORRECTED;
    ef_pipe_cb_t cb = {0};
    cb.on_move = bc_on_move;
    cb.on_setpoint = bc_on_sp;
    cb.user = &g_path;
    ef_pipe_stats_t st;
    if (ef_pipe_run(&rd, &pc, &cb, &st, &m) != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return 2;
    }
    ef_gcode_free(&rd);
    memcpy(g_path.end, st.end, sizeof g_path.end);
    memcpy(g_path.start, st.start, sizeof g_path.start);
    g_path.duration = st.cycle_time;
    printf("path %s: %zu moves, %.3f s at the programmed feed, %zu setpoints at 1 kHz; 3 axes,"
           " 3 drives, bus 1 Mbit/s\n",
           prog, g_path.nmv, g_path.duration, g_path.nsp);
    bc_result_t csp, seg;
    int rc = bc_stream(EF_COM_MODE_CSP, &csp);
    rc |= bc_stream(EF_COM_MODE_SEGMENT, &seg);
    bc_print("CSP, SYNC 1 kHz", &csp);
    bc_print("segment mode, SYNC 100 Hz", &seg);
    if (rc != 0) {
        fprintf(stderr, "bench_canbus: a run failed\n");
        return 1;
    }
    double ratio = (seg.bits / seg.seconds) / (csp.bits / csp.seconds);
    printf("segment mode / CSP bus load: %.3f (1/%.1f); target <= 1/5: %s\n", ratio, 1.0 / ratio,
           ratio <= 0.2 ? "met" : "NOT MET");
    return 0;
}
