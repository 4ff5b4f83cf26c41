/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target for the CANopen code that handles untrusted bus input: the drive
 * (ef_codrive_rx / process) and the master (ef_comaster_rx / process). The input bytes
 * are decoded into a stream of frames (biased towards the identifiers each side acts on:
 * NMT, SYNC, PDOs, law records, SDO, EMCY, heartbeat, plus any 11-bit or 29-bit identifier,
 * RTR, any length) interleaved with elapsed time and with a port that sometimes answers
 * "queue full". The drive may first be brought to OPERATION ENABLED (CSP or segment mode)
 * by well-formed frames, so the fuzzer starts where a running drive is.
 *
 * Invariants (a broken one aborts, saving the input):
 *  - every frame either side sends is a classic 11-bit data frame of at most 8 bytes;
 *  - the drive's positions stay finite, its power state and drive state are valid ones;
 *  - the master never sends ENABLE OPERATION to a node whose TPDO1 (its state) it has not
 *    seen, and an ERROR state always carries an error code.
 *
 * Built with -DEF_FUZZ_REPLAY_MAIN it is a plain-C replay driver (canopen_fuzz_replay
 * DIR|FILE...): every seed ("ok-*") must run without breaking an invariant.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Report and crash, so the input is saved as a reproducer. */
static void fz_fail(const char *what, long a)
{
    fprintf(stderr, "canopen fuzz invariant broken: %s (%ld)\n", what, a);
    abort();
}

typedef struct {
    const uint8_t *d;
    size_t n, i;
} fz_in_t;

/* Next input byte (zeros after the end). */
static uint8_t fz_u8(fz_in_t *in)
{
    return in->i < in->n ? in->d[in->i++] : 0;
}

/* The side under test and what its port saw. */
typedef struct {
    int master;          /* 1: the master is under test */
    ef_comaster_t *m;    /* for the ENABLE check */
    uint32_t again_mask; /* bit pattern: which sends answer EF_ERR_AGAIN */
    uint32_t sends;
} fz_ctx_t;

/* The port: check every frame sent; sometimes refuse it (queue full). */
static int fz_send(void *ctx, const ef_can_frame_t *f)
{
    fz_ctx_t *c = ctx;
    c->sends++;
    if (f->dlc > 8)
        fz_fail("frame longer than 8 bytes", f->dlc);
    if (f->flags != 0)
        fz_fail("RTR or 29-bit frame sent", f->flags);
    if (f->id > 0x7FFu)
        fz_fail("identifier beyond 11 bits", (long)f->id);
    if (c->master && (f->id & ~0x7Fu) == EF_CO_COB_RPDO1 && f->dlc >= 2) {
        uint16_t cw = ef_co_get16(f->data);
        if ((cw & 0x0Fu) == 0x0Fu && !(cw & 0x80u)) {
            int known = 0;
            for (int k = 0; k < c->m->cfg.n_nodes; k++)
                if (c->m->cfg.nodes[k] == (f->id & 0x7Fu))
                    known = c->m->node[k].seen_tpdo;
            if (!known)
                fz_fail("ENABLE OPERATION to a node whose state was never read", (long)f->id);
        }
    }
    if ((c->again_mask >> (c->sends % 32u)) & 1u)
        return EF_ERR_AGAIN;
    return EF_OK;
}

/* Identifier families the two sides act on (node n added where it applies). */
static uint32_t fz_id(fz_in_t *in)
{
    uint8_t sel = fz_u8(in), n = (uint8_t)(1u + (sel & 3u)); /* nodes 1..3, 4 = a stranger */
    switch (sel >> 3) {
    case 0:
        return EF_CO_COB_NMT;
    case 1:
        return EF_CO_COB_SYNC;
    case 2:
        return EF_CO_COB_RPDO1 + n;
    case 3:
        return EF_CO_COB_RPDO2 + n;
    case 4:
        return EF_CO_LAW_COBID;
    case 5:
        return EF_CO_COB_SDO_RX + n;
    case 6:
        return EF_CO_COB_TPDO1 + n;
    case 7:
        return EF_CO_COB_SDO_TX + n;
    case 8:
        return EF_CO_COB_EMCY + n;
    case 9:
        return EF_CO_COB_HEARTBEAT + n;
    case 10:
        return EF_CO_COB_RPDO3 + n;
    default: {
        uint32_t a = fz_u8(in), b = fz_u8(in);
        return (a | (b << 8)) & 0x7FFu;
    }
    }
}

/* An expedited SDO write to node 1 (the drive's bring-up). */
static void fz_sdo(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t v, int len)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = EF_CO_COB_SDO_RX + 1u;
    f.dlc = 8;
    f.data[0] = (uint8_t)(0x23u | ((uint32_t)(4 - len) << 2));
    ef_co_put16(f.data + 1, idx);
    f.data[3] = sub;
    ef_co_put32(f.data + 4, v);
    (void)ef_codrive_rx(d, &f);
}

/* A frame with data to the drive. */
static void fz_frame(ef_codrive_t *d, uint32_t id, uint8_t dlc, const uint8_t *data)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = dlc;
    if (dlc)
        memcpy(f.data, data, dlc);
    (void)ef_codrive_rx(d, &f);
}

/* Bring the drive to OPERATION ENABLED with well-formed frames (CSP or segment mode). */
static void fz_drive_up(ef_codrive_t *d, int segment)
{
    uint32_t next = 0;
    (void)ef_codrive_process(d, 1000u, &next);
    fz_sdo(d, EF_CO_OBJ_CYCLE, 0, 1000u, 4);
    fz_sdo(d, EF_CO_OBJ_HB_PRODUCER, 0, 50u, 2);
    fz_sdo(d, EF_CO_OBJ_MODE, 0, segment ? 0xFFu : 8u, 1);
    if (segment) {
        /* RPDO2 (axis chunks) and RPDO3 (law chunks) mapped and enabled. */
        static const uint16_t comm[2] = {0x1401u, 0x1402u}, map[2] = {0x1601u, 0x1602u};
        static const uint32_t cob[2] = {EF_CO_COB_RPDO2 + 1u, EF_CO_LAW_COBID};
        static const uint16_t obj[2] = {EF_CO_OBJ_SEG_AXIS, EF_CO_OBJ_SEG_LAW};
        for (int k = 0; k < 2; k++) {
            fz_sdo(d, comm[k], 1, cob[k] | EF_CO_PDO_INVALID, 4);
            fz_sdo(d, comm[k], 2, 255u, 1);
            fz_sdo(d, map[k], 0, 0u, 1);
            fz_sdo(d, map[k], 1, EF_CO_MAP(obj[k], 0, 64), 4);
            fz_sdo(d, map[k], 0, 1u, 1);
            fz_sdo(d, comm[k], 1, cob[k], 4);
        }
    }
    uint8_t nmt[2] = {EF_CO_NMT_START, 1};
    fz_frame(d, EF_CO_COB_NMT, 2, nmt);
    static const uint16_t cws[3] = {EF_CO_CW_SHUTDOWN, EF_CO_CW_SWITCH_ON, EF_CO_CW_ENABLE_OP};
    for (int i = 0; i < 3; i++) {
        uint8_t r[6] = {0};
        ef_co_put16(r, cws[i]);
        ef_co_put32(r + 2, 0u);
        fz_frame(d, EF_CO_COB_RPDO1 + 1u, 6, r);
        fz_frame(d, EF_CO_COB_SYNC, 0, r);
    }
}

/* Drive-side invariants. */
static void fz_check_drive(const ef_codrive_t *d)
{
    float p = ef_codrive_position(d);
    if (!(p == p) || fabsf(p) > 1e9f)
        fz_fail("drive position not finite", 0);
    if (!(d->drv.cmd.x == d->drv.cmd.x))
        fz_fail("drive command not finite", 0);
    if (d->power > EF_CO_PS_FAULT)
        fz_fail("drive power state invalid", d->power);
    if (d->drv.state > EF_DRV_FAULT)
        fz_fail("drive model state invalid", d->drv.state);
}

static ef_codrive_t fz_d;
static ef_comaster_t fz_m;

/* One input: frames and time to one side. */
static void fz_run(const uint8_t *data, size_t size)
{
    fz_in_t in = {data, size, 0};
    uint8_t mode = fz_u8(&in);
    fz_ctx_t ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.master = mode & 1u;
    ctx.m = &fz_m;
    ctx.again_mask = (mode & 0x40u) ? (uint32_t)fz_u8(&in) * 0x01010101u : 0u;
    ef_can_port_t port = {fz_send, &ctx};
    if (ctx.master) {
        ef_com_cfg_t c;
        ef_comaster_cfg_default(&c, (mode & 2u) ? EF_COM_MODE_SEGMENT : EF_COM_MODE_CSP);
        c.n_nodes = 3;
        for (int k = 0; k < 3; k++)
            c.nodes[k] = (uint8_t)(k + 1);
        c.fault_reset = (mode >> 2) & 1u;
        if (ef_comaster_init(&fz_m, &c, &port) != EF_OK)
            fz_fail("master init refused its defaults", 0);
    } else {
        ef_codrive_cfg_t c;
        ef_codrive_cfg_default(&c, 1);
        if (ef_codrive_init(&fz_d, &c, &port) != EF_OK)
            fz_fail("drive init refused its defaults", 0);
        if (mode & 4u)
            fz_drive_up(&fz_d, (mode & 2u) != 0);
    }
    for (int guard = 0; guard < 4096 && in.i < in.n; guard++) {
        ef_can_frame_t f;
        memset(&f, 0, sizeof f);
        f.id = fz_id(&in);
        uint8_t len = fz_u8(&in);
        f.dlc = (uint8_t)(len & 0x0Fu); /* up to 15: longer than 8 is malformed */
        if (len & 0x80u)
            f.flags = (uint8_t)((len >> 4) & 3u); /* RTR / EFF now and then */
        if (f.flags & EF_CAN_FLAG_EFF)
            f.id |= (uint32_t)fz_u8(&in) << 11;
        for (int i = 0; i < 8; i++)
            f.data[i] = i < f.dlc ? fz_u8(&in) : 0;
        uint32_t dt = (uint32_t)fz_u8(&in) * 100u, next = 0;
        if (ctx.master) {
            (void)ef_comaster_rx(&fz_m, &f);
            (void)ef_comaster_process(&fz_m, dt, &next);
            if (ef_comaster_state(&fz_m) == EF_COM_ERROR && ef_comaster_error(&fz_m)->code == 0)
                fz_fail("master in ERROR without an error code", 0);
            if (ef_comaster_state(&fz_m) == EF_COM_RUN && (dt & 0x100u)) {
                float t[3] = {0.0f, 0.0f, 0.0f};
                (void)ef_comaster_push_target(&fz_m, t);
            }
        } else {
            (void)ef_codrive_rx(&fz_d, &f);
            (void)ef_codrive_process(&fz_d, dt, &next);
            fz_check_drive(&fz_d);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_run(data, size);
    return 0;
}

#ifdef EF_FUZZ_REPLAY_MAIN
#include "replay.h"

/* Every input is acceptable; breaking an invariant aborts. */
static int replay_canopen(const uint8_t *buf, size_t len, char *why, size_t why_len)
{
    (void)why;
    (void)why_len;
    fz_run(buf, len);
    return 0;
}

int main(int argc, char **argv)
{
    return ef_replay_main(argc, argv, replay_canopen);
}
#endif
