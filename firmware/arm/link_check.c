/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Cortex-M4F link check: a complete freestanding image (own vector table and reset code,
 * no C runtime start files) that builds one G1 cubic and one G2 quintic segment through
 * small tables defined here, then runs a short program (lines and an arc) through the
 * streaming smoother, the feed planner and the interpolator, as a controller would; and a
 * drive-side Modbus register device (ef_modbus.h, ef_drive.h) that receives one encoded
 * straight-line slot and executes it; and a CANopen master (ef_comaster.h) bringing up
 * one CiA 402 drive (ef_codrive.h) over an in-memory bus and streaming it a few CSP targets.
 * firmware/arm/build.sh links it against libef_fw.a with
 * --gc-sections and inspects the result: whatever the library drags in shows up there
 * (heap, stdio, double-precision soft-float helpers would all be failures).
 *
 * It is not meant to be flashed as an application, but it is a valid one: the reset code
 * sets up .data/.bss and the FPU before main, as a real board's startup must.
 */
#include <stdint.h>
#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/modbus/ef_modbus.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/table/ef_table.h"

#define LC_PI 3.14159265f

/* G1 fold table, 3 x 5 nodes over (u, v) in [0, pi/2] x [0, pi]: DOFs (x1_0, x1_1). */
static const float lc_g1_data[3 * 5 * 2] = {
    1.0f, 1.0f, 1.1f, 0.9f, 1.2f, 0.8f, 0.9f, 1.1f, 1.0f, 1.0f, 1.1f, 0.9f, 0.8f, 1.2f, 0.9f,
    1.1f, 1.0f, 1.0f, 0.7f, 1.3f, 0.8f, 1.2f, 0.9f, 1.1f, 0.6f, 1.4f, 0.7f, 1.3f, 0.8f, 1.2f,
};

static const ef_table_t lc_g1 = {
    .kind = EF_TABLE_G1_CUBIC,
    .symmetry = EF_SYM_G1_FOLD,
    .naxes = 2,
    .ndof = 2,
    .quad_nodes = 16,
    .nodes = 15,
    .x1_min = 0.1f,
    .x1_max = 4.0f,
    .x2_max = 0.0f,
    .axis = {{0.0f, 0.5f * LC_PI, 2.0f / (0.5f * LC_PI), 3, 1, 0},
             {0.0f, LC_PI, 4.0f / LC_PI, 5, 3, 0}},
    .data = lc_g1_data,
};

/* G2 mirror table, 2 x 3 x 3 x 3 nodes over alpha in [0, pi/2], beta in [-pi/2, pi/2],
 * k0, k1 in [-2, 2]: DOFs (x1_0, x2_0, x1_1, x2_1), here the same at every node. */
#define LC_G2_NODE 1.0f, 0.5f, 1.0f, -0.5f
#define LC_G2_ROW3 LC_G2_NODE, LC_G2_NODE, LC_G2_NODE
#define LC_G2_ROW9 LC_G2_ROW3, LC_G2_ROW3, LC_G2_ROW3
static const float lc_g2_data[2 * 3 * 3 * 3 * 4] = {
    LC_G2_ROW9, LC_G2_ROW9, LC_G2_ROW9, LC_G2_ROW9, LC_G2_ROW9, LC_G2_ROW9,
};

static const ef_table_t lc_g2 = {
    .kind = EF_TABLE_G2_QUINTIC,
    .symmetry = EF_SYM_G2_MIRROR,
    .naxes = 4,
    .ndof = 4,
    .quad_nodes = 16,
    .nodes = 54,
    .x1_min = 0.1f,
    .x1_max = 4.0f,
    .x2_max = 50.0f,
    .axis = {{0.0f, 0.5f * LC_PI, 1.0f / (0.5f * LC_PI), 2, 1, 0},
             {-0.5f * LC_PI, 0.5f * LC_PI, 2.0f / LC_PI, 3, 2, 0},
             {-2.0f, 2.0f, 0.5f, 3, 6, 0},
             {-2.0f, 2.0f, 0.5f, 3, 18, 0}},
    .data = lc_g2_data,
};

/* End data in RAM (.data) and results in .bss, volatile so nothing is folded away. */
static volatile ef_endpoint_t lc_e0 = {
    {0.0f, 0.0f, 0.0f}, {0.8f, 0.6f, 0.0f}, {-0.6f, 0.8f, 0.0f}, 0.5f};
static volatile ef_endpoint_t lc_e1 = {
    {10.0f, 2.0f, 1.0f}, {0.6f, 0.0f, 0.8f}, {0.0f, 1.0f, 0.0f}, -0.25f};
static volatile float lc_sink[2 * 6 * 3];
static volatile int lc_status;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);

/* Copy the volatile end data into a plain struct for the library calls. */
static ef_endpoint_t lc_load(const volatile ef_endpoint_t *v)
{
    ef_endpoint_t e;
    e.p = ef_v3(v->p.x, v->p.y, v->p.z);
    e.t = ef_v3(v->t.x, v->t.y, v->t.z);
    e.n = ef_v3(v->n.x, v->n.y, v->n.z);
    e.kappa = v->kappa;
    return e;
}

/* The whole runtime: smoother, planner and interpolator in static storage (their sizes
 * show in the image's .bss), a square with a rounded corner pushed as primitives, the moves
 * pulled into the interpolator and stepped at 1 ms until the queue is idle. */
static ef_smooth_t lc_smooth;
static ef_interp_t lc_interp;
static volatile float lc_pos[3];

static int lc_run_smoother(void)
{
    ef_smooth_cfg_t cfg = {0};
    cfg.g2 = &lc_g2;
    cfg.g1 = &lc_g1;
    for (int i = 0; i < 3; i++) {
        cfg.lim.v_axis[i] = 100.0f;
        cfg.lim.a_axis[i] = 1000.0f;
    }
    cfg.lim.a_normal_frac = 0.5f;
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;
    ef_vec3_t home = ef_v3(0.0f, 0.0f, 0.0f);
    int rc = ef_smooth_init(&lc_smooth, &cfg, home);
    rc |= ef_interp_init(&lc_interp, home, 1000u, EF_STEP_CORRECTED);
    ef_prim_t pr[4] = {{0}};
    for (int i = 0; i < 4; i++) {
        pr[i].kind = EF_PRIM_LINE;
        pr[i].feed = 50.0f;
        pr[i].tol = 0.01f;
        pr[i].tag = (uint32_t)i;
    }
    pr[0].end = ef_v3(20.0f, 0.0f, 0.0f);
    pr[1].kind = EF_PRIM_ARC; /* quarter circle about (20, 5) */
    pr[1].centre = ef_v3(20.0f, 5.0f, 0.0f);
    pr[1].axis = ef_v3(0.0f, 0.0f, 1.0f);
    pr[1].sweep = 0.5f * LC_PI;
    pr[1].end = ef_v3(25.0f, 5.0f, 0.0f);
    pr[2].end = ef_v3(25.0f, 20.0f, 0.0f);
    pr[3].end = ef_v3(0.0f, 20.0f, 0.0f);
    ef_move_t m;
    int have = 0, done = 0;
    uint32_t next = 0;
    for (uint32_t tick = 0; tick < 100000u; tick++) {
        /* one work unit a call: a push not taken yet (EF_ERR_FULL) is repeated */
        if (next < 4u) {
            int prc = ef_smooth_push(&lc_smooth, &pr[next]);
            if (prc == EF_OK)
                next++;
            else if (prc != EF_ERR_FULL)
                return 1;
        } else if (!done) {
            int frc = ef_smooth_finish(&lc_smooth);
            done = frc == EF_OK;
            if (frc != EF_OK && frc != EF_ERR_FULL)
                rc |= frc;
        }
        if (!have)
            have = ef_smooth_pull(&lc_smooth, &m) == EF_OK;
        if (have && ef_interp_space(&lc_interp) > 0u) {
            rc |= ef_interp_push(&lc_interp, &m);
            have = 0;
        }
        ef_setpoint_t sp;
        uint32_t next_us;
        rc |= ef_interp_process(&lc_interp, 1000u, &next_us, &sp);
        lc_pos[0] = sp.p.x;
        lc_pos[1] = sp.p.y;
        lc_pos[2] = sp.p.z;
        if (done && !have && !sp.moving && ef_interp_space(&lc_interp) == EF_INTERP_QUEUE)
            break;
    }
    return rc != EF_OK;
}

/* The drive side: a register device in static storage, enabled and started through the
 * control word, one straight-line segment written as an encoded slot, then stepped at
 * 1 ms until the segment is done. */
static ef_mbdev_t lc_dev;

static int lc_run_drive(void)
{
    ef_servo_cfg_t cfg;
    ef_servo_cfg_default(&cfg);
    ef_vec3_t home = ef_v3(0.0f, 0.0f, 0.0f);
    int rc = ef_mbdev_init(&lc_dev, &cfg, home, 1000u, 0x5A5Au);
    uint8_t exc = 0u;
    uint16_t ctl = EF_MB_CTL_ENABLE;
    rc |= ef_mbdev_write(&lc_dev, EF_MB_REG_CONTROL, 1u, &ctl, &exc);
    ef_move_t m = {0};
    m.degree = 1;
    m.flags = EF_MOVE_STOP_END;
    m.b[0] = home;
    m.b[1] = ef_v3(3.0f, 4.0f, 0.0f);
    m.length = 5.0f;
    m.duration = 0.2f; /* tau = 2u/D - (u/D)^2: from 50 units/s down to rest */
    m.law.dt[0] = 0.2f;
    m.law.c[0][1] = 10.0f;
    m.law.c[0][2] = -25.0f;
    static uint16_t slot[EF_MB_SLOT_WORDS];
    rc |= ef_mb_slot_encode(&m, slot);
    rc |= ef_mbdev_write(&lc_dev, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, slot, &exc);
    ctl = EF_MB_CTL_ENABLE | EF_MB_CTL_START;
    rc |= ef_mbdev_write(&lc_dev, EF_MB_REG_CONTROL, 1u, &ctl, &exc);
    uint16_t done[2] = {0u, 0u};
    for (uint32_t tick = 0; tick < 1000u; tick++) {
        uint32_t next_us;
        rc |= ef_mbdev_process(&lc_dev, 1000u, &next_us);
        rc |= ef_mbdev_read(&lc_dev, EF_MB_REG_DONE_SEQ, 2u, done, &exc);
        if (ef_mb_get_u32(done) == 0u)
            break;
    }
    lc_pos[0] = lc_dev.drv.act.x;
    lc_pos[1] = lc_dev.drv.act.y;
    lc_pos[2] = lc_dev.drv.act.z;
    return rc != EF_OK || ef_mb_get_u32(done) != 0u;
}

/* CANopen: a master and one drive on an in-memory bus (a ring each way), as two nodes of a
 * real bus would exchange frames through their controllers. */
#define LC_BUSQ 64u
typedef struct {
    ef_can_frame_t q[LC_BUSQ];
    uint32_t head, count;
} lc_busq_t;
static lc_busq_t lc_to_drive, lc_to_master;
static ef_comaster_t lc_master;
static ef_codrive_t lc_codrive;

/* The HAL send op of either node: queue the frame for the other one. */
static int lc_can_send(void *ctx, const ef_can_frame_t *f)
{
    lc_busq_t *q = ctx;
    if (q->count == LC_BUSQ)
        return EF_ERR_AGAIN;
    q->q[(q->head + q->count) % LC_BUSQ] = *f;
    q->count++;
    return EF_OK;
}

/* Deliver everything queued in both directions. */
static void lc_can_deliver(void)
{
    for (uint32_t guard = 0; guard < 4u * LC_BUSQ && (lc_to_drive.count || lc_to_master.count);
         guard++) {
        if (lc_to_drive.count) {
            (void)ef_codrive_rx(&lc_codrive, &lc_to_drive.q[lc_to_drive.head]);
            lc_to_drive.head = (lc_to_drive.head + 1u) % LC_BUSQ;
            lc_to_drive.count--;
        }
        if (lc_to_master.count) {
            (void)ef_comaster_rx(&lc_master, &lc_to_master.q[lc_to_master.head]);
            lc_to_master.head = (lc_to_master.head + 1u) % LC_BUSQ;
            lc_to_master.count--;
        }
    }
}

/* Bring the drive up in CSP and stream a short ramp; 0 when it got there. */
static int lc_run_canopen(void)
{
    ef_com_cfg_t mc;
    ef_comaster_cfg_default(&mc, EF_COM_MODE_CSP);
    mc.n_nodes = 1;
    mc.nodes[0] = 1;
    ef_codrive_cfg_t dc;
    ef_codrive_cfg_default(&dc, 1);
    ef_can_port_t pm = {lc_can_send, &lc_to_drive}, pd = {lc_can_send, &lc_to_master};
    int rc = ef_comaster_init(&lc_master, &mc, &pm);
    rc |= ef_codrive_init(&lc_codrive, &dc, &pd);
    float x = 0.0f;
    for (uint32_t tick = 0; tick < 20000u && rc == EF_OK; tick++) {
        uint32_t next_us;
        (void)ef_comaster_process(&lc_master, 100u, &next_us);
        (void)ef_codrive_process(&lc_codrive, 100u, &next_us);
        lc_can_deliver();
        int st = ef_comaster_state(&lc_master);
        if (st == EF_COM_RUN && x < 1.0f && ef_comaster_push_target(&lc_master, &x) == EF_OK)
            x += 0.01f;
        if (st == EF_COM_RUN && x >= 1.0f)
            (void)ef_comaster_finish(&lc_master);
        if (st == EF_COM_DONE || st == EF_COM_ERROR)
            break;
    }
    lc_pos[0] = ef_codrive_position(&lc_codrive);
    return rc != EF_OK || ef_comaster_state(&lc_master) != EF_COM_DONE;
}

/* Build both segments and publish their control points; then run the smoother, the drive
 * and the CANopen pair. */
int main(void)
{
    ef_endpoint_t e0 = lc_load(&lc_e0), e1 = lc_load(&lc_e1);
    ef_seg_t s3, s5;
    int rc3 = ef_seg_g1_cubic(&lc_g1, &e0, &e1, &s3);
    int rc5 = ef_seg_g2_quintic(&lc_g2, &e0, &e1, &s5);
    for (int i = 0; i < 6; i++) {
        lc_sink[3 * i] = s3.b[i].x;
        lc_sink[3 * i + 1] = s3.b[i].y;
        lc_sink[3 * i + 2] = s3.b[i].z;
        lc_sink[18 + 3 * i] = s5.b[i].x;
        lc_sink[18 + 3 * i + 1] = s5.b[i].y;
        lc_sink[18 + 3 * i + 2] = s5.b[i].z;
    }
    lc_status = (rc3 == EF_OK && rc5 == EF_OK) ? 0 : 1;
    lc_status |= lc_run_smoother() << 1;
    lc_status |= lc_run_drive() << 2;
    lc_status |= lc_run_canopen() << 3;
    return lc_status;
}

/* Symbols from link_check.ld. */
extern uint32_t _estack, _sidata, _sdata, _edata, _sbss, _ebss;

/* Copy .data from flash, zero .bss, enable the FPU (CP10/CP11 full access in CPACR, which
 * must precede any floating-point instruction), run main, then stay put. */
void Reset_Handler(void)
{
    const uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;)
        *dst++ = *src++;
    for (uint32_t *dst = &_sbss; dst < &_ebss;)
        *dst++ = 0u;
    volatile uint32_t *cpacr = (volatile uint32_t *)0xE000ED88u;
    *cpacr |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    (void)main();
    for (;;) {
    }
}

/* Any unexpected exception parks the core here. */
void Default_Handler(void)
{
    for (;;) {
    }
}

/* One entry of the vector table: the initial stack pointer, then handlers. */
typedef union {
    uint32_t *stack;
    void (*handler)(void);
} lc_vector_t;

/* The 16 Cortex-M system vectors; a board would append its interrupt lines. */
__attribute__((section(".isr_vector"), used)) static const lc_vector_t lc_vectors[16] = {
    {.stack = &_estack},
    {.handler = Reset_Handler},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
    {.stack = 0},
    {.stack = 0},
    {.stack = 0},
    {.stack = 0},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
    {.stack = 0},
    {.handler = Default_Handler},
    {.handler = Default_Handler},
};
