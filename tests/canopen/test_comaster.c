/* SPDX-License-Identifier: Apache-2.0 */
/* CANopen master (ef_comaster) tests.
 *
 * Scripted parts: a fake port captures the master's frames and small fake drives written
 * here answer them (SDO server over a toy object dictionary, a CiA 402 power state machine
 * stepped at SYNC, TPDO1 after SYNC), with injectable misbehaviour: silence at boot, SDO
 * aborts, wrong device type, lost or malformed SDO answers, a drive in FAULT, a busy or
 * failed port; the caller's SDO transfers (segmented download frames, wrong toggle, retry and
 * timeout).
 *
 * Integration parts: the master and real ef_codrive drives, each on its own pump, on the
 * in-memory bus (ef_canrig.h: CSP ramp and circle, segment-mode moves, go-back-N after a lost
 * chunk, EMCY mid-path, heartbeat loss, the caller's SDO transfers while streaming). */
#include <stdint.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/host/can/ef_canrig.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"

extern const ef_table_t ef_tbl_g2_default;

/* ------------------------------------------------------------------ fake port + drives */

#define FK_NODES 3
#define FK_TXLOG 20000
#define FK_OBJS  96
#define FK_NAME  "fake servo drive 01" /* 19 bytes: a segmented upload */
#define SW_SOD   0x0440u
#define SW_READY 0x0421u
#define SW_SWON  0x0423u
#define SW_OP    0x0427u
#define SW_FAULT 0x0408u

typedef struct {
    uint16_t index;
    uint8_t sub;
    uint32_t value;
} fk_obj_t;

typedef struct {
    uint8_t id;
    int silent;           /* never answers anything (no boot-up) */
    uint32_t devtype;     /* 0x1000 */
    uint16_t abort_index; /* abort an access to this object ... */
    uint8_t abort_sub;
    uint32_t abort_code;
    uint16_t drop_index; /* ... drop requests for this one drop_n times */
    int drop_n;
    uint16_t bad_index; /* answer this one with a wrong index echoed (bad_kind 0) or dlc 7 */
    int bad_kind;
    uint16_t sw;
    int32_t pos;
    uint16_t cw_latched, cw_prev;
    int has_latched;
    int operational;
    int saw_enable_op; /* an RPDO1 with ENABLE OPERATION reached it */
    int saw_fault_reset;
    fk_obj_t od[FK_OBJS];
    int n_od;
    /* segmented upload */
    uint32_t up_pos;
    int up_toggle;
    /* segmented download */
    uint16_t dl_index;
    uint8_t dl_sub;
    uint32_t dl_size, dl_pos;
    int dl_toggle;
    uint8_t dl_buf[64];
    int dl_done;       /* segmented downloads completed (last segment received) */
    int dl_bad_toggle; /* answer segments with the toggle bit inverted */
    int dl_drop_seg;   /* leave this many segments unanswered */
} fk_drive_t;

typedef struct {
    ef_comaster_t m;
    fk_drive_t d[FK_NODES];
    int n;
    ef_can_frame_t log[FK_TXLOG];
    int n_log, seen;
    int again_n;     /* port answers AGAIN this many times */
    int again_every; /* ... or every k-th send (0: never) */
    int sends;
    int bus_fail; /* port answers BUS */
    uint32_t hb_us;
} fk_t;

static fk_t F;

/* The fake port: log the frame unless it is refused. */
static int fk_send(void *ctx, const ef_can_frame_t *f)
{
    fk_t *x = (fk_t *)ctx;
    x->sends++;
    if (x->bus_fail)
        return EF_ERR_BUS;
    if (x->again_n > 0) {
        x->again_n--;
        return EF_ERR_AGAIN;
    }
    if (x->again_every && x->sends % x->again_every == 0)
        return EF_ERR_AGAIN;
    if (x->n_log < FK_TXLOG)
        x->log[x->n_log++] = *f;
    return EF_OK;
}

/* A frame from a fake drive to the master. */
static void fk_reply(uint32_t id, const uint8_t *d, uint8_t dlc)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = dlc;
    memcpy(f.data, d, dlc);
    ef_comaster_rx(&F.m, &f);
}

static uint32_t *fk_obj(fk_drive_t *d, uint16_t index, uint8_t sub)
{
    for (int i = 0; i < d->n_od; i++)
        if (d->od[i].index == index && d->od[i].sub == sub)
            return &d->od[i].value;
    if (d->n_od >= FK_OBJS)
        return NULL;
    d->od[d->n_od].index = index;
    d->od[d->n_od].sub = sub;
    d->od[d->n_od].value = 0;
    return &d->od[d->n_od++].value;
}

/* Toy SDO server: one download segment (data collected, toggle answered, maybe wrongly). */
static void fk_sdo_dl_seg(fk_drive_t *d, const ef_can_frame_t *f)
{
    uint8_t r[8] = {0}, cmd = f->data[0];
    uint32_t n = 7u - ((cmd >> 1) & 7u);
    int t = (cmd >> 4) & 1;
    EF_CHECK_EQ(t, d->dl_toggle);
    if (d->dl_pos + n <= sizeof d->dl_buf)
        memcpy(d->dl_buf + d->dl_pos, &f->data[1], n);
    d->dl_pos += n;
    d->dl_toggle ^= 1;
    if (cmd & 1u) {
        EF_CHECK_EQ(d->dl_pos, d->dl_size);
        d->dl_done++;
    }
    if (d->dl_drop_seg > 0) {
        d->dl_drop_seg--;
        return;
    }
    r[0] = (uint8_t)(0x20 | ((t ^ (d->dl_bad_toggle ? 1 : 0)) << 4));
    fk_reply(EF_CO_COB_SDO_TX + d->id, r, 8);
}

/* Toy SDO server. */
static void fk_sdo(fk_drive_t *d, const ef_can_frame_t *f)
{
    uint8_t r[8] = {0};
    uint16_t index = ef_co_get16(&f->data[1]);
    uint8_t sub = f->data[3], cmd = f->data[0];
    uint32_t tx = EF_CO_COB_SDO_TX + d->id;
    if ((cmd & 0xE0u) == 0x00u) {
        fk_sdo_dl_seg(d, f);
        return;
    }
    if ((cmd & 0xE0u) == 0x60u && index == 0 && sub == 0) {
        /* upload segment request (bytes 1..7 are zero) */
        uint32_t len = (uint32_t)strlen(FK_NAME);
        uint32_t n = len - d->up_pos > 7 ? 7 : len - d->up_pos;
        int last = d->up_pos + n >= len;
        r[0] = (uint8_t)((d->up_toggle ? 0x10 : 0) | ((7 - n) << 1) | (last ? 1 : 0));
        memcpy(&r[1], &FK_NAME[d->up_pos], n);
        d->up_pos += n;
        d->up_toggle ^= 1;
        fk_reply(tx, r, 8);
        return;
    }
    if (d->drop_index == index && d->drop_n > 0) {
        d->drop_n--;
        return;
    }
    r[1] = f->data[1];
    r[2] = f->data[2];
    r[3] = sub;
    if (d->abort_index == index && d->abort_sub == sub) {
        r[0] = 0x80;
        ef_co_put32(&r[4], d->abort_code);
        fk_reply(tx, r, 8);
        return;
    }
    if (d->bad_index == index) {
        if (d->bad_kind == 0) {
            ef_co_put16(&r[1], (uint16_t)(index + 1));
            r[0] = (cmd & 0xE0u) == 0x20u ? 0x60 : 0x43;
            fk_reply(tx, r, 8);
        } else {
            r[0] = 0x60;
            fk_reply(tx, r, 7);
        }
        return;
    }
    /* Segmented download initiate (the size is indicated). */
    if ((cmd & 0xE0u) == 0x20u && !(cmd & 0x02u)) {
        EF_CHECK_EQ(cmd, 0x21);
        d->dl_index = index;
        d->dl_sub = sub;
        d->dl_size = ef_co_get32(&f->data[4]);
        d->dl_pos = 0;
        d->dl_toggle = 0;
        r[0] = 0x60;
        fk_reply(tx, r, 8);
        return;
    }
    if ((cmd & 0xE0u) == 0x20u) { /* expedited download */
        uint32_t *v = fk_obj(d, index, sub);
        if (v)
            *v = ef_co_get32(&f->data[4]);
        r[0] = 0x60;
        fk_reply(tx, r, 8);
        return;
    }
    /* upload initiate */
    uint32_t v = 0;
    if (index == EF_CO_OBJ_DEVICE_NAME) {
        r[0] = 0x41;
        ef_co_put32(&r[4], (uint32_t)strlen(FK_NAME));
        d->up_pos = 0;
        d->up_toggle = 0;
        fk_reply(tx, r, 8);
        return;
    }
    if (index == EF_CO_OBJ_DEVICE_TYPE)
        v = d->devtype;
    else if (index == EF_CO_OBJ_SUPPORTED)
        v = (1u << 7) | (1u << 16);
    else if (index == EF_CO_OBJ_INC_PER_UNIT)
        v = 10000u;
    else if (index == EF_CO_OBJ_MODE_DISPLAY)
        v = *fk_obj(d, EF_CO_OBJ_MODE, 0) & 0xFFu;
    else
        v = *fk_obj(d, index, sub);
    r[0] = 0x43;
    ef_co_put32(&r[4], v);
    fk_reply(tx, r, 8);
}

/* Power state machine step at SYNC with the latched controlword. */
static void fk_sync(fk_drive_t *d)
{
    if (d->has_latched) {
        uint16_t cw = d->cw_latched;
        if (d->sw == SW_FAULT) {
            if ((cw & 0x80u) && !(d->cw_prev & 0x80u))
                d->sw = SW_SOD;
        } else if (!(cw & 0x2u)) {
            d->sw = SW_SOD;
        } else if ((cw & 0x7u) == 0x2u) { /* quick stop: at rest at once */
            d->sw = SW_SOD;
        } else if ((cw & 0x8Fu) == 0x06u) {
            d->sw = SW_READY;
        } else if ((cw & 0x8Fu) == 0x07u && d->sw == SW_READY) {
            d->sw = SW_SWON;
        } else if ((cw & 0x8Fu) == 0x0Fu && (d->sw == SW_SWON || d->sw == SW_OP)) {
            d->sw = SW_OP;
        }
        d->cw_prev = cw;
    }
    uint8_t t[8] = {0, 0, 0, 0, 0, 0, 0, 16}; /* segment mode: next 0, 16 free places */
    ef_co_put16(t, d->sw);
    ef_co_put32(&t[2], (uint32_t)d->pos);
    fk_reply(EF_CO_COB_TPDO1 + d->id, t, *fk_obj(d, EF_CO_OBJ_MODE, 0) == 0xFFu ? 8 : 6);
}

/* One master frame reaching the fake drives. */
static void fk_deliver(const ef_can_frame_t *f)
{
    for (int k = 0; k < F.n; k++) {
        fk_drive_t *d = &F.d[k];
        if (d->silent)
            continue;
        if (f->id == EF_CO_COB_NMT && (f->data[1] == 0 || f->data[1] == d->id)) {
            if (f->data[0] == EF_CO_NMT_RESET_COMM) {
                uint8_t b = 0;
                d->operational = 0;
                fk_reply(EF_CO_COB_HEARTBEAT + d->id, &b, 1);
            } else if (f->data[0] == EF_CO_NMT_START) {
                d->operational = 1;
            }
        } else if (f->id == EF_CO_COB_SDO_RX + d->id && f->dlc == 8) {
            fk_sdo(d, f);
        } else if (f->id == EF_CO_COB_SYNC && d->operational) {
            fk_sync(d);
        } else if (f->id == EF_CO_COB_RPDO1 + d->id) {
            d->cw_latched = ef_co_get16(f->data);
            d->has_latched = 1;
            if ((d->cw_latched & 0x8Fu) == 0x0Fu)
                d->saw_enable_op = 1;
            if (d->cw_latched & 0x80u)
                d->saw_fault_reset = 1;
        }
    }
}

/* Advance the master by dt and let the fakes answer everything it sent. */
static void fk_step(uint32_t dt)
{
    ef_comaster_process(&F.m, dt, NULL);
    F.hb_us += dt;
    if (F.hb_us >= 50000u) { /* every fake that was told a heartbeat period produces one */
        F.hb_us = 0;
        for (int k = 0; k < F.n; k++) {
            uint8_t st = F.d[k].operational ? EF_CO_NMT_OPERATIONAL : EF_CO_NMT_PREOPERATIONAL;
            if (!F.d[k].silent && *fk_obj(&F.d[k], EF_CO_OBJ_HB_PRODUCER, 0) != 0)
                fk_reply(EF_CO_COB_HEARTBEAT + F.d[k].id, &st, 1);
        }
    }
    for (int guard = 0; guard < 100000 && F.seen < F.n_log; guard++)
        fk_deliver(&F.log[F.seen++]);
}

/* Run until state st (or any final state) or the time runs out. */
static void fk_run_until(int st, uint32_t max_us)
{
    for (uint32_t t = 0; t < max_us; t += 500) {
        int s = ef_comaster_state(&F.m);
        if (s == st || s == EF_COM_DONE || s == EF_COM_ERROR)
            return;
        fk_step(500);
    }
}

static ef_com_cfg_t fk_cfg(int mode)
{
    ef_com_cfg_t c;
    ef_comaster_cfg_default(&c, mode);
    c.n_nodes = FK_NODES;
    for (int k = 0; k < FK_NODES; k++)
        c.nodes[k] = (uint8_t)(5 + k);
    return c;
}

/* Fresh fakes and master. */
static void fk_setup(const ef_com_cfg_t *c)
{
    memset(&F, 0, sizeof F);
    F.n = c->n_nodes;
    for (int k = 0; k < F.n; k++) {
        F.d[k].id = c->nodes[k];
        F.d[k].devtype = EF_CO_DEVICE_TYPE_402;
        F.d[k].sw = SW_SOD;
        F.d[k].pos = 1000 * (k + 1);
    }
    ef_can_port_t p = {fk_send, &F};
    EF_CHECK_EQ(ef_comaster_init(&F.m, c, &p), EF_OK);
}

/* Frames in the log with this id (and, for SDO, this index; 0: any). */
static int fk_count(uint32_t id, uint16_t index)
{
    int n = 0;
    for (int i = 0; i < F.n_log; i++)
        if (F.log[i].id == id && (index == 0 || ef_co_get16(&F.log[i].data[1]) == index))
            n++;
    return n;
}

/* ------------------------------------------------------------------ scripted parts */

static void t_args(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    ef_can_port_t p = {fk_send, &F}, nop = {NULL, NULL};
    ef_comaster_t *m = &F.m;
    EF_CHECK_EQ(ef_comaster_init(NULL, &c, &p), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_init(m, &c, &nop), EF_ERR_ARG);
    c.nodes[1] = c.nodes[0];
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_ERR_ARG);
    c = fk_cfg(EF_COM_MODE_CSP);
    c.nodes[2] = 128;
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_ERR_ARG);
    c = fk_cfg(EF_COM_MODE_CSP);
    c.cycle_us = 0;
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_ERR_ARG);
    c = fk_cfg(EF_COM_MODE_CSP);
    c.n_nodes = 0;
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_ERR_ARG);
    c = fk_cfg(7);
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_ERR_ARG);
    c = fk_cfg(EF_COM_MODE_CSP);
    EF_CHECK_EQ(ef_comaster_init(m, &c, &p), EF_OK);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_BOOT);
    float pos[3] = {0, 0, 0};
    EF_CHECK_EQ(ef_comaster_push_target(m, pos), EF_ERR_STATE);
    ef_move_t mv;
    memset(&mv, 0, sizeof mv);
    EF_CHECK_EQ(ef_comaster_push_move(m, &mv), EF_ERR_ARG); /* CSP master */
    EF_CHECK_EQ(ef_comaster_finish(m), EF_ERR_STATE);
    EF_CHECK(ef_comaster_node(m, 3) == NULL);
    EF_CHECK(ef_comaster_node(m, 0) != NULL);
    EF_CHECK_EQ(ef_comaster_error(m)->code, 0);
}

/* Happy path with the fakes: bring-up, CSP targets sent, finish -> DONE. */
static void t_fake_csp(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_RUN);
    EF_CHECK(strcmp(ef_comaster_name(&F.m, 1), FK_NAME) == 0);
    EF_CHECK_EQ(ef_comaster_node(&F.m, 2)->inc_per_unit, 10000);
    /* Mapping written and read back: RPDO1 two entries. */
    EF_CHECK_EQ(*fk_obj(&F.d[0], EF_CO_OBJ_RPDO_MAP, 0), 2);
    EF_CHECK_EQ(*fk_obj(&F.d[0], EF_CO_OBJ_RPDO_COMM, 1), EF_CO_COB_RPDO1 + 5);
    EF_CHECK_EQ(*fk_obj(&F.d[0], EF_CO_OBJ_CYCLE, 0), 1000);
    /* The first target is the actual position: the last RPDO1 to node 6 holds 2000. */
    int last = -1;
    for (int i = 0; i < F.n_log; i++)
        if (F.log[i].id == EF_CO_COB_RPDO1 + 6)
            last = i;
    EF_CHECK(last >= 0);
    EF_CHECK_EQ((int32_t)ef_co_get32(&F.log[last].data[2]), 2000);
    float p[3] = {1.5f, -0.25f, 0.0001f};
    EF_CHECK_EQ(ef_comaster_push_target(&F.m, p), EF_OK);
    float bad[3] = {1e30f, 0, 0};
    EF_CHECK_EQ(ef_comaster_push_target(&F.m, bad), EF_ERR_NONFINITE);
    int mark = F.n_log;
    fk_step(1000);
    int got = 0;
    for (int i = mark; i < F.n_log; i++)
        if (F.log[i].id == EF_CO_COB_RPDO1 + 5) {
            EF_CHECK_EQ((int32_t)ef_co_get32(&F.log[i].data[2]), 15000);
            EF_CHECK_EQ(ef_co_get16(F.log[i].data), EF_CO_CW_ENABLE_OP);
            got++;
        } else if (F.log[i].id == EF_CO_COB_RPDO1 + 6) {
            EF_CHECK_EQ((int32_t)ef_co_get32(&F.log[i].data[2]), -2500);
        }
    EF_CHECK_EQ(got, 1);
    EF_CHECK_EQ(ef_comaster_finish(&F.m), EF_OK);
    fk_run_until(EF_COM_DONE, 1000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_DONE);
    EF_CHECK_EQ(F.d[0].sw, SW_READY); /* SHUTDOWN: operation disabled */
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, 0);
}

static void t_boot(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    F.d[1].silent = 1;
    fk_run_until(EF_COM_ERROR, 5000000);
    const ef_com_error_t *e = ef_comaster_error(&F.m);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_ERROR);
    EF_CHECK_EQ(e->code, EF_ERR_HEARTBEAT);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_BOOT);
    EF_CHECK_EQ(e->node, 6);
    EF_CHECK(F.m.now_us >= 3000000u && F.m.now_us < 3100000u);
    EF_CHECK_EQ(fk_count(EF_CO_COB_NMT, 0), 1); /* the reset, nothing started */
}

static void t_abort(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    F.d[2].abort_index = EF_CO_OBJ_TPDO_MAP;
    F.d[2].abort_sub = 2;
    F.d[2].abort_code = EF_CO_ABORT_NO_MAP;
    fk_run_until(EF_COM_ERROR, 3000000);
    const ef_com_error_t *e = ef_comaster_error(&F.m);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_ERROR);
    EF_CHECK_EQ(e->code, EF_ERR_PROTO);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_SDO_WRITE);
    EF_CHECK_EQ(e->node, 7);
    EF_CHECK_EQ(e->index, EF_CO_OBJ_TPDO_MAP);
    EF_CHECK_EQ(e->sub, 2);
    EF_CHECK_EQ(e->abort, EF_CO_ABORT_NO_MAP);
    EF_CHECK(strcmp(ef_co_abort_str(e->abort), "unknown abort code") != 0);
    EF_CHECK_EQ(fk_count(EF_CO_COB_SYNC, 0), 0); /* never started */
}

static void t_devtype(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_SEGMENT);
    fk_setup(&c);
    F.d[1].devtype = 0x00020191u;
    fk_run_until(EF_COM_ERROR, 3000000);
    const ef_com_error_t *e = ef_comaster_error(&F.m);
    EF_CHECK_EQ(e->code, EF_ERR_PROTO);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_CHECK);
    EF_CHECK_EQ(e->node, 6);
    EF_CHECK_EQ(e->index, EF_CO_OBJ_DEVICE_TYPE);
    EF_CHECK_EQ(e->value, 0x00020191u);
    EF_CHECK_EQ(e->expected, EF_CO_DEVICE_TYPE_402);
}

static void t_sdo_timeout(void)
{
    /* One lost request: the retry carries it. */
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    F.d[0].drop_index = EF_CO_OBJ_SUPPORTED;
    F.d[0].drop_n = 1;
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_RUN);
    EF_CHECK_EQ(fk_count(EF_CO_COB_SDO_RX + 5, EF_CO_OBJ_SUPPORTED), 2);
    /* Two: the error names node and object, after two timeouts. */
    fk_setup(&c);
    F.d[1].drop_index = EF_CO_OBJ_INC_PER_UNIT;
    F.d[1].drop_n = 2;
    fk_run_until(EF_COM_ERROR, 3000000);
    const ef_com_error_t *e = ef_comaster_error(&F.m);
    EF_CHECK_EQ(e->code, EF_ERR_TIMEOUT);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_SDO_READ);
    EF_CHECK_EQ(e->node, 6);
    EF_CHECK_EQ(e->index, EF_CO_OBJ_INC_PER_UNIT);
    EF_CHECK_EQ(fk_count(EF_CO_COB_SDO_RX + 6, EF_CO_OBJ_INC_PER_UNIT), 2);
}

static void t_malformed(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    F.d[0].bad_index = EF_CO_OBJ_CYCLE; /* wrong index echoed */
    fk_run_until(EF_COM_ERROR, 3000000);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->index, EF_CO_OBJ_CYCLE);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->node, 5);
    fk_setup(&c);
    F.d[2].bad_index = EF_CO_OBJ_FERR_WINDOW; /* dlc 7 */
    F.d[2].bad_kind = 1;
    fk_run_until(EF_COM_ERROR, 3000000);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->node, 7);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->index, EF_CO_OBJ_FERR_WINDOW);
    EF_CHECK_EQ(ef_comaster_node(&F.m, 2)->rx_bad, 1);
    /* An SDO answer nobody asked for is counted, not an error. */
    fk_setup(&c);
    fk_run_until(EF_COM_RUN, 3000000);
    uint8_t r[8] = {0x60, 0, 0x10, 0, 0, 0, 0, 0};
    fk_reply(EF_CO_COB_SDO_TX + 6, r, 8);
    fk_reply(EF_CO_COB_HEARTBEAT + 6, r, 2); /* wrong length heartbeat */
    EF_CHECK_EQ(ef_comaster_node(&F.m, 1)->rx_bad, 2);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_RUN);
}

static void t_fault(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_SEGMENT);
    fk_setup(&c);
    F.d[1].sw = SW_FAULT;
    fk_run_until(EF_COM_ERROR, 3000000);
    const ef_com_error_t *e = ef_comaster_error(&F.m);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_ERROR);
    EF_CHECK_EQ(e->code, EF_ERR_DRIVE);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_FAULT);
    EF_CHECK_EQ(e->node, 6);
    EF_CHECK_EQ(e->power, EF_CO_PS_FAULT);
    for (int k = 0; k < 3; k++)
        EF_CHECK(!F.d[k].saw_enable_op);
    EF_CHECK(!F.d[1].saw_fault_reset);
    /* With fault_reset the fault is reset and the node enabled. */
    c.fault_reset = 1;
    fk_setup(&c);
    F.d[1].sw = SW_FAULT;
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_RUN);
    EF_CHECK(F.d[1].saw_fault_reset);
    EF_CHECK_EQ(F.d[1].sw, SW_OP);
}

static void t_again(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    F.again_every = 3; /* a third of the sends find the port busy */
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_RUN);
    EF_CHECK(F.m.txq.again > 10);
    EF_CHECK_EQ(F.m.txq.lost, 0);
    F.again_every = 0;
    fk_step(100); /* drain what the busy port left queued */
    EF_CHECK_EQ(F.m.txq.count, 0);
    F.again_n = 3;
    float p[3] = {1, 2, 3};
    EF_CHECK_EQ(ef_comaster_push_target(&F.m, p), EF_OK);
    int mark = F.n_log;
    fk_step(1000); /* SYNC refused: it and the three RPDO1 behind it wait */
    EF_CHECK_EQ(F.n_log - mark, 0);
    EF_CHECK_EQ(F.m.txq.count, 4);
    fk_step(100); /* refused twice more */
    fk_step(100);
    EF_CHECK_EQ(F.m.txq.count, 4);
    fk_step(100);
    EF_CHECK_EQ(F.m.txq.count, 0);
    EF_CHECK_EQ(F.n_log - mark, 4); /* in order: SYNC first, then the three RPDO1 */
    EF_CHECK_EQ(F.log[mark].id, EF_CO_COB_SYNC);
    EF_CHECK_EQ(F.log[mark + 3].id, EF_CO_COB_RPDO1 + 7);
    EF_CHECK_EQ((int32_t)ef_co_get32(&F.log[mark + 3].data[2]), 30000);
}

static void t_bus(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_bus_error(&F.m, 0xB0u), EF_OK);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_STOPPING);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, EF_ERR_BUS);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->what, EF_COM_WHAT_BUS);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->value, 0xB0u);
    fk_step(1000);
    int qs = 0;
    for (int i = F.n_log - 4; i < F.n_log; i++)
        qs +=
            F.log[i].id == EF_CO_COB_RPDO1 + 5 && ef_co_get16(F.log[i].data) == EF_CO_CW_QUICK_STOP;
    EF_CHECK_EQ(qs, 1);
    fk_run_until(EF_COM_ERROR, 1000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_ERROR);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, EF_ERR_BUS);
    /* The port itself reporting bus-off: same, and the stop frames wait in the queue. */
    fk_setup(&c);
    fk_run_until(EF_COM_RUN, 3000000);
    F.bus_fail = 1;
    EF_CHECK_EQ(ef_comaster_process(&F.m, 1000, NULL), EF_ERR_BUS);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_STOPPING);
    EF_CHECK(F.m.txq.count > 0);
    F.bus_fail = 0; /* the bus recovers: the stop goes out */
    fk_run_until(EF_COM_ERROR, 1000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_ERROR);
    EF_CHECK_EQ(F.d[0].sw, SW_READY);
    /* A requested stop ends DONE. */
    fk_setup(&c);
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_stop(&F.m), EF_OK);
    fk_run_until(EF_COM_DONE, 1000000);
    EF_CHECK_EQ(ef_comaster_state(&F.m), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&F.m)->code, 0);
}

/* Segment mode against the fakes: the configured layout (the drive is not simulated). */
static void t_fake_seg(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_SEGMENT);
    fk_setup(&c);
    fk_run_until(EF_COM_START, 3000000);
    fk_drive_t *d = &F.d[0];
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_RPDO_COMM + 2, 1), EF_CO_LAW_COBID);
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_RPDO_COMM + 2, 2), 255);
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_RPDO_MAP + 1, 1), EF_CO_MAP(EF_CO_OBJ_SEG_AXIS, 0, 64));
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_TPDO_MAP, 0), 4);
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_TPDO_MAP, 4),
                EF_CO_MAP(EF_CO_OBJ_SEG_STATUS, EF_CO_SEGST_FREE, 8));
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_TPDO_COMM + 1, 1) & EF_CO_PDO_INVALID, EF_CO_PDO_INVALID);
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_MODE, 0), 0xFF);
    EF_CHECK_EQ(*fk_obj(d, EF_CO_OBJ_CYCLE, 0), 10000);
}

/* Step the fakes until the caller's SDO transfer is no longer pending; its result. */
static int fk_sdo_wait(void)
{
    int rc = ef_comaster_sdo_result(&F.m, NULL, NULL, NULL);
    for (int i = 0; i < 4000 && rc == EF_ERR_AGAIN; i++) {
        fk_step(500);
        rc = ef_comaster_sdo_result(&F.m, NULL, NULL, NULL);
    }
    return rc;
}

/* SDO frames the master sent node id since log position mark, into out (at most max). */
static int fk_sdo_frames(uint8_t id, int mark, ef_can_frame_t *out, int max)
{
    int n = 0;
    for (int i = mark; i < F.n_log; i++)
        if (F.log[i].id == EF_CO_COB_SDO_RX + id) {
            if (n < max)
                out[n] = F.log[i];
            n++;
        }
    return n;
}

/* An 8-byte SDO answer from node 5's server. */
static ef_can_frame_t sc_answer(uint8_t cmd, uint16_t index, uint8_t sub, uint32_t v)
{
    ef_can_frame_t f = {0};
    f.id = EF_CO_COB_SDO_TX + 5u;
    f.dlc = 8;
    f.data[0] = cmd;
    ef_co_put16(&f.data[1], index);
    f.data[3] = sub;
    ef_co_put32(&f.data[4], v);
    return f;
}

/* A 1-byte write of 0x1602:00 to node at t0 that times out, is retried at t0 + 1000 and is
 * answered once at t0 + 1100: its second answer is still due (the client's timeout is
 * 1000 us). */
static void sc_retried_write(ef_sdo_client_t *c, uint8_t node, uint32_t t0)
{
    const uint8_t one[1] = {1};
    ef_can_frame_t out, a = sc_answer(0x60, 0x1602, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_download(c, node, 0x1602, 0, one, 1, t0, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_process(c, t0 + 1000u, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(out.dlc, 8);
    EF_CHECK_EQ(ef_sdo_client_rx(c, &a, t0 + 1100u, &out), EF_OK);
}

/* The SDO client on its own (ef_sdo_client.h), frame by frame through its transition table:
 * expedited and segmented download and upload (exact frames, toggles, the value and the data
 * cut to the buffer), aborts with and without echo, a wrong toggle, a malformed answer, the
 * timeout's one retry from the initiate, no_retry(), abandon(), and the argument and state
 * errors. */
static void t_sdo_client(void)
{
    ef_sdo_client_t c;
    ef_can_frame_t out, a;
    uint32_t abort = 1, len = 1;
    const uint8_t *data = NULL;
    const uint8_t two[2] = {0x34, 0x12};
    EF_CHECK_EQ(ef_sdo_client_init(NULL, 1000), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_init(&c, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_init(&c, 1000), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, &data, &len), EF_ERR_STATE);
    EF_CHECK(abort == 0 && data == NULL && len == 0);
    EF_CHECK_EQ(ef_sdo_client_result(NULL, NULL, NULL, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_busy(&c), 0);
    EF_CHECK_EQ(ef_sdo_client_due_us(&c, 0), 0xFFFFFFFFu);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 5000, &out), EF_ERR_STATE);
    EF_CHECK_EQ(out.dlc, 0);
    a = sc_answer(0x60, 0x1017, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_STATE); /* nothing asked */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 0, 0x1017, 0, two, 2, 0, &out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 128, 0x1017, 0, two, 2, 0, &out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1017, 0, two, 0, 0, &out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1017, 0, NULL, 2, 0, &out), EF_ERR_ARG);
    uint8_t big[EF_SDO_CLIENT_BUF + 1];
    for (uint32_t i = 0; i < sizeof big; i++)
        big[i] = (uint8_t)(0xB0 + i);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x2345, 1, big, EF_SDO_CLIENT_BUF + 1, 0, &out),
                EF_ERR_ARG);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 0, 0x1000, 0, 0, &out), EF_ERR_ARG);

    /* Expedited download of 2 bytes: 0x2B (n = 2, e, s), echoed index/sub; done on 0x60. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1017, 0, two, 2, 100, &out), EF_OK);
    EF_CHECK_EQ(out.id, EF_CO_COB_SDO_RX + 5u);
    EF_CHECK_EQ(out.dlc, 8);
    EF_CHECK_EQ(out.data[0], 0x2B);
    EF_CHECK_EQ(ef_co_get16(&out.data[1]), 0x1017);
    EF_CHECK_EQ(ef_co_get32(&out.data[4]), 0x1234);
    EF_CHECK_EQ(c.state, EF_SDOC_DL_INIT);
    EF_CHECK_EQ(ef_sdo_client_busy(&c), 1);
    EF_CHECK_EQ(ef_sdo_client_result(&c, NULL, NULL, NULL), EF_ERR_AGAIN);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_ERR_STATE);
    a = sc_answer(0x60, 0x1017, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(c.state, EF_SDOC_IDLE);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, &data, &len), EF_OK);
    EF_CHECK(abort == 0 && data == NULL && len == 0); /* a download has no data */

    /* Segmented download of 10 bytes: initiate with the size, 7 bytes toggle 0, 3 bytes
     * toggle 1 with c; each confirmed with its toggle. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x2345, 1, big, 10, 300, &out), EF_OK);
    EF_CHECK_EQ(out.data[0], 0x21);
    EF_CHECK_EQ(ef_co_get32(&out.data[4]), 10);
    a = sc_answer(0x60, 0x2345, 1, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 400, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(c.state, EF_SDOC_DL_SEG);
    EF_CHECK_EQ(out.data[0], 0x00);
    EF_CHECK_EQ(out.data[1], 0xB0);
    EF_CHECK_EQ(out.data[7], 0xB6);
    a = sc_answer(0x20, 0, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 500, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(out.data[0], 0x19); /* toggle 1, n = 4 (3 bytes), c */
    EF_CHECK_EQ(out.data[1], 0xB7);
    EF_CHECK_EQ(out.data[3], 0xB9);
    EF_CHECK_EQ(ef_sdo_client_due_us(&c, 600), 900); /* the timer restarted with the segment */
    a = sc_answer(0x30, 0, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 600, &out), EF_OK);
    /* ... and a wrong toggle in a confirmation: abort code 0x05030000. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x2345, 1, big, 10, 0, &out), EF_OK);
    a = sc_answer(0x60, 0x2345, 1, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_AGAIN);
    a = sc_answer(0x30, 0, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, NULL, NULL), EF_ERR_PROTO);
    EF_CHECK_EQ(abort, EF_CO_ABORT_TOGGLE);

    /* Expedited upload of 1 byte: the value masked, 1 byte of data. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x6061, 0, 0, &out), EF_OK);
    EF_CHECK_EQ(out.data[0], 0x40);
    EF_CHECK_EQ(c.state, EF_SDOC_UL_INIT);
    a = sc_answer(0x4F, 0x6061, 0, 0xDDCCBBFFu);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_value(&c), 0xFF);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, &data, &len), EF_OK);
    EF_CHECK(len == 1 && data && data[0] == 0xFF && abort == 0);

    /* Segmented upload longer than the buffer: segment requests 0x60, 0x70, ...; the data cut
     * to EF_SDO_CLIENT_BUF, the value its first 4 bytes. */
    uint32_t total = EF_SDO_CLIENT_BUF + 5u;
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1008, 0, 0, &out), EF_OK);
    a = sc_answer(0x41, 0x1008, 0, total);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(c.state, EF_SDOC_UL_SEG);
    EF_CHECK_EQ(out.data[0], 0x60);
    uint32_t sent = 0;
    int rc = EF_ERR_AGAIN;
    for (int t = 0; rc == EF_ERR_AGAIN && t < 20; t++) {
        uint32_t n = total - sent < 7u ? total - sent : 7u;
        ef_can_frame_t s = {0};
        s.id = EF_CO_COB_SDO_TX + 5u;
        s.dlc = 8;
        s.data[0] = (uint8_t)(((t & 1) << 4) | ((7u - n) << 1) | (sent + n == total ? 1u : 0u));
        for (uint32_t i = 0; i < n; i++)
            s.data[1 + i] = (uint8_t)(sent + i);
        sent += n;
        rc = ef_sdo_client_rx(&c, &s, 0, &out);
        if (rc == EF_ERR_AGAIN)
            EF_CHECK_EQ(out.data[0], (t & 1) ? 0x60 : 0x70);
    }
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(ef_sdo_client_result(&c, NULL, &data, &len), EF_OK);
    EF_CHECK_EQ(len, EF_SDO_CLIENT_BUF);
    EF_CHECK(data && data[0] == 0 && data[EF_SDO_CLIENT_BUF - 1] == EF_SDO_CLIENT_BUF - 1);
    EF_CHECK_EQ(ef_sdo_client_value(&c), 0x03020100u);
    EF_CHECK_EQ(c.got, total);

    /* Aborts: echoed (its code), not echoed (abort 0); a malformed answer (7 bytes). */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_OK);
    a = sc_answer(EF_CO_SDO_ABORT, 0x1000, 0, EF_CO_ABORT_NO_OBJECT);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, &data, &len), EF_ERR_PROTO);
    EF_CHECK(abort == EF_CO_ABORT_NO_OBJECT && data == NULL && len == 0);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_OK);
    a = sc_answer(EF_CO_SDO_ABORT, 0x1001, 0, EF_CO_ABORT_NO_OBJECT);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, NULL, NULL), EF_ERR_PROTO);
    EF_CHECK_EQ(abort, 0);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_OK);
    a = sc_answer(0x43, 0x1000, 0, 0x00020192u);
    a.dlc = 7;
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_PROTO);
    /* A download answered as an upload: the wrong specifier. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1017, 0, two, 2, 0, &out), EF_OK);
    a = sc_answer(0x43, 0x1017, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_PROTO);

    /* Timeout: nothing before it is due; then the initiate again (the whole transfer
     * restarts, here a segmented download half done), then the failure. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x2345, 1, big, 10, 0xFFFFFF00u, &out), EF_OK);
    a = sc_answer(0x60, 0x2345, 1, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0xFFFFFF00u, &out), EF_ERR_AGAIN); /* a segment out */
    EF_CHECK_EQ(ef_sdo_client_process(&c, 0xFFFFFF00u + 999u, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 0xFFFFFF00u + 1000u, &out), EF_ERR_AGAIN); /* wraps */
    EF_CHECK_EQ(out.dlc, 8);
    EF_CHECK_EQ(out.data[0], 0x21);
    EF_CHECK_EQ(c.state, EF_SDOC_DL_INIT);
    EF_CHECK_EQ(ef_sdo_client_due_us(&c, 0xFFFFFF00u + 1000u), 1000);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 0xFFFFFF00u + 2000u, &out), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(ef_sdo_client_result(&c, &abort, NULL, NULL), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(abort, 0);
    /* no_retry(): the first timeout fails it. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_OK);
    ef_sdo_client_no_retry(&c);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 1000, &out), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(out.dlc, 0);
    /* abandon(): idle, no outcome, a late answer ignored. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1000, 0, 0, &out), EF_OK);
    ef_sdo_client_abandon(&c);
    EF_CHECK_EQ(ef_sdo_client_busy(&c), 0);
    EF_CHECK_EQ(ef_sdo_client_result(&c, NULL, NULL, NULL), EF_ERR_STATE);
    a = sc_answer(0x43, 0x1000, 0, 0x00020192u);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 0, &out), EF_ERR_STATE);
    /* A slow server answers both the request and its retry (seen in hil_can_segment under
     * load: a read of 0x1A00:00 retried, its second answer arriving during the next write):
     * the next transfer with that server holds its initiate back until the duplicate came,
     * ignores it, and completes on its own answer. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1A00, 0, 0, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 1000, &out), EF_ERR_AGAIN); /* the retry */
    EF_CHECK_EQ(out.dlc, 8);
    a = sc_answer(0x4F, 0x1A00, 0, 2);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 1100, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_value(&c), 2u);
    const uint8_t cob[4] = {0x82, 0x01, 0, 0x80};
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1800, 1, cob, 4, 1200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 0); /* held */
    EF_CHECK_EQ(ef_sdo_client_busy(&c), 1);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 1210, &out), EF_ERR_AGAIN); /* the duplicate */
    EF_CHECK_EQ(out.dlc, 8);                                         /* now the write's initiate */
    EF_CHECK_EQ(out.data[0], 0x23);
    EF_CHECK_EQ(ef_co_get16(&out.data[1]), 0x1800);
    EF_CHECK_EQ(c.stale_ignored, 1u);
    a = sc_answer(0x60, 0x1800, 1, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 1220, &out), EF_OK);
    /* Only one: a second copy is the error it always was. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1A00, 0, 2000, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 3000, &out), EF_ERR_AGAIN);
    a = sc_answer(0x4F, 0x1A00, 0, 2);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 3100, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1800, 1, cob, 4, 3200, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 3210, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 3220, &out), EF_ERR_PROTO);
    /* Without a retry, an answer echoing the last transfer is no duplicate: an error. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 5, 0x1A00, 0, 4000, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 4100, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_download(&c, 5, 0x1800, 1, cob, 4, 4200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 8); /* nothing held */
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 4210, &out), EF_ERR_PROTO);

    /* hil_gsusb_segment under load (350 ms from request to answer through the adapter): a
     * write of 0x1602:00 retried, then its read-back. The duplicate write answer echoes the
     * same object; had the read gone out, it would have been taken for the read's (the wrong
     * specifier: an error). Held, the read goes out after it and reads the value. */
    sc_retried_write(&c, 2, 5000);
    a = sc_answer(0x60, 0x1602, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 2, 0x1602, 0, 6200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 6300, &out), EF_ERR_AGAIN);
    EF_CHECK(out.dlc == 8 && out.data[0] == 0x40 && ef_co_get16(&out.data[1]) == 0x1602);
    EF_CHECK_EQ(ef_sdo_client_due_us(&c, 6300), 1000); /* its own full timeout */
    a = sc_answer(0x4F, 0x1602, 0, 1);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 6400, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_value(&c), 1u);
    /* A duplicate that never comes (the first request was lost): the held initiate goes
     * after one timeout. */
    sc_retried_write(&c, 2, 7000);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 2, 0x1602, 0, 8200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(ef_sdo_client_due_us(&c, 8200), 1000);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 9199, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 9200, &out), EF_ERR_AGAIN);
    EF_CHECK(out.dlc == 8 && out.data[0] == 0x40);
    a = sc_answer(0x4F, 0x1602, 0, 1);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 9300, &out), EF_OK);
    /* ... a transfer with another server is not held (its late answer is not routed here);
     * while held, anything but the duplicate is an error. */
    sc_retried_write(&c, 2, 10000);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 3, 0x1602, 0, 11200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 8);
    a = sc_answer(0x4F, 0x1602, 0, 1);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 11300, &out), EF_OK);
    sc_retried_write(&c, 3, 12000);
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 3, 0x1603, 0, 13200, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 0);
    a = sc_answer(0x4F, 0x1603, 0, 1);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 13300, &out), EF_ERR_PROTO);

    /* hil_gsusb_faults under load: a segmented upload (0x1008:00) retried at its initiate.
     * The first answer starts the segments; the retry's own answer, arriving in the segment
     * phase, is ignored, and the transfer completes. */
    uint32_t st0 = c.stale_ignored;
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 4, 0x1008, 0, 20000, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_process(&c, 21000, &out), EF_ERR_AGAIN);
    a = sc_answer(0x41, 0x1008, 0, 3);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 21100, &out), EF_ERR_AGAIN);
    EF_CHECK(c.state == EF_SDOC_UL_SEG && out.data[0] == 0x60);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 21110, &out), EF_ERR_AGAIN); /* the duplicate */
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(c.stale_ignored, st0 + 1u);
    ef_can_frame_t sg = sc_answer(0x09, 0, 0, 0); /* toggle 0, 3 bytes, last */
    sg.data[1] = 'a';
    sg.data[2] = 'b';
    sg.data[3] = 'c';
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &sg, 21200, &out), EF_OK);
    EF_CHECK_EQ(ef_sdo_client_result(&c, NULL, &data, &len), EF_OK);
    EF_CHECK(len == 3 && data && data[0] == 'a' && data[2] == 'c');
    /* ... and after the transfer, nothing is held: the duplicate was seen. */
    EF_CHECK_EQ(ef_sdo_client_upload(&c, 4, 0x1000, 0, 21300, &out), EF_OK);
    EF_CHECK_EQ(out.dlc, 8);
    ef_sdo_client_abandon(&c);
    /* Retried at a segment (its answer lost or late): the late segment answer, arriving while
     * the retry's initiate waits, is ignored; the transfer restarts and completes. */
    EF_CHECK_EQ(ef_sdo_client_download(&c, 4, 0x2345, 1, big, 10, 30000, &out), EF_OK);
    a = sc_answer(0x60, 0x2345, 1, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 30100, &out), EF_ERR_AGAIN); /* segment 0 out */
    EF_CHECK_EQ(ef_sdo_client_process(&c, 31100, &out), EF_ERR_AGAIN);
    EF_CHECK(c.state == EF_SDOC_DL_INIT && out.data[0] == 0x21);
    ef_can_frame_t ack0 = sc_answer(0x20, 0, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &ack0, 31200, &out), EF_ERR_AGAIN); /* the late ack */
    EF_CHECK_EQ(out.dlc, 0);
    EF_CHECK_EQ(c.state, EF_SDOC_DL_INIT);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &a, 31300, &out), EF_ERR_AGAIN);
    EF_CHECK(c.state == EF_SDOC_DL_SEG && out.data[0] == 0x00);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &ack0, 31400, &out), EF_ERR_AGAIN);
    EF_CHECK_EQ(out.data[0], 0x19);
    ef_can_frame_t ack1 = sc_answer(0x30, 0, 0, 0);
    EF_CHECK_EQ(ef_sdo_client_rx(&c, &ack1, 31500, &out), EF_OK);
}

/* The caller's SDO client against the fakes: argument and state checks, the exact frames of
 * a 10-byte segmented download, a wrong toggle, a retry from the initiate, a timeout, and a
 * transfer after the end (DONE). */
static void t_sdo_segdl_fake(void)
{
    ef_com_cfg_t c = fk_cfg(EF_COM_MODE_CSP);
    fk_setup(&c);
    const uint8_t pay[10] = {0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7, 0xA8, 0xA9};
    uint8_t big[EF_COM_SDO_BUF + 1];
    memset(big, 0x5A, sizeof big);
    ef_comaster_t *m = &F.m;
    /* During bring-up the master owns the client. */
    EF_CHECK_EQ(ef_comaster_sdo_result(m, NULL, NULL, NULL), EF_ERR_STATE);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_ERR_STATE);
    EF_CHECK_EQ(ef_comaster_sdo_read(m, 0, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_STATE);
    fk_run_until(EF_COM_CONFIG, 100000);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_CONFIG);
    EF_CHECK_EQ(ef_comaster_sdo_read(m, 0, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_STATE);
    fk_run_until(EF_COM_RUN, 3000000);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, NULL, NULL, NULL), EF_ERR_STATE); /* none started */
    EF_CHECK_EQ(ef_comaster_sdo_result(NULL, NULL, NULL, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(NULL, 1, 0x2345, 1, pay, 10), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 3, 0x2345, 1, pay, 10), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, -1, 0x2345, 1, pay, 10), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, NULL, 10), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, big, EF_COM_SDO_BUF + 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_read(m, 3, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_comaster_sdo_read(NULL, 0, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_ARG);

    /* 10 bytes: initiate 0x21 with the size, then 7 bytes (toggle 0), then 3 (toggle 1, c). */
    fk_drive_t *d = &F.d[1];
    int mark = F.n_log;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 0, 0x2345, 1, pay, 10), EF_ERR_STATE); /* pending */
    EF_CHECK_EQ(ef_comaster_sdo_read(m, 2, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_STATE);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, NULL, NULL, NULL), EF_ERR_AGAIN);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    ef_can_frame_t fr[8];
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 3);
    const uint8_t init[8] = {0x21, 0x45, 0x23, 0x01, 10, 0, 0, 0};
    const uint8_t seg0[8] = {0x00, 0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6};
    const uint8_t seg1[8] = {0x19, 0xA7, 0xA8, 0xA9, 0, 0, 0, 0}; /* t 1, n 4, c */
    EF_CHECK(fr[0].dlc == 8 && memcmp(fr[0].data, init, 8) == 0);
    EF_CHECK(fr[1].dlc == 8 && memcmp(fr[1].data, seg0, 8) == 0);
    EF_CHECK(fr[2].dlc == 8 && memcmp(fr[2].data, seg1, 8) == 0);
    EF_CHECK_EQ(d->dl_done, 1);
    EF_CHECK_EQ(d->dl_index, 0x2345);
    EF_CHECK_EQ(d->dl_sub, 1);
    EF_CHECK(memcmp(d->dl_buf, pay, 10) == 0);
    uint32_t ab = 7, n = 7;
    const uint8_t *dp = pay;
    EF_CHECK_EQ(ef_comaster_sdo_result(m, &ab, &dp, &n), EF_OK);
    EF_CHECK_EQ(ab, 0);
    EF_CHECK(dp == NULL);
    EF_CHECK_EQ(n, 0);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, NULL, NULL, NULL), EF_OK); /* stays */

    /* Up to 4 bytes: expedited (3 bytes: n = 1). */
    mark = F.n_log;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2346, 2, pay, 3), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 1);
    EF_CHECK_EQ(fr[0].data[0], 0x27);
    EF_CHECK_EQ(*fk_obj(d, 0x2346, 2), 0xA2A1A0u);
    /* The 7-byte segment limit exactly: 14 bytes in two full segments, c on the second. */
    mark = F.n_log;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, big, 14), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 3);
    EF_CHECK_EQ(fr[1].data[0], 0x00);
    EF_CHECK_EQ(fr[2].data[0], 0x11);
    EF_CHECK_EQ(d->dl_done, 2);

    /* A wrong toggle bit in the server's answer. */
    d->dl_bad_toggle = 1;
    mark = F.n_log;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, &ab, &dp, &n), EF_ERR_PROTO);
    EF_CHECK_EQ(ab, EF_CO_ABORT_TOGGLE);
    EF_CHECK(dp == NULL);
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 2); /* nothing after the bad answer */
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_error(m)->code, 0);
    d->dl_bad_toggle = 0;

    /* A server abort at the initiate. */
    d->abort_index = 0x2345;
    d->abort_sub = 1;
    d->abort_code = EF_CO_ABORT_NO_OBJECT;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, &ab, NULL, NULL), EF_ERR_PROTO);
    EF_CHECK_EQ(ab, EF_CO_ABORT_NO_OBJECT);
    d->abort_index = 0;

    /* A lost segment answer: the retry restarts the transfer from the initiate. */
    d->dl_drop_seg = 1;
    mark = F.n_log;
    uint32_t t0 = m->now_us;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 5);
    EF_CHECK(memcmp(fr[2].data, init, 8) == 0);
    EF_CHECK(memcmp(fr[3].data, seg0, 8) == 0);
    EF_CHECK(memcmp(fr[4].data, seg1, 8) == 0);
    EF_CHECK(m->now_us - t0 >= 200000u && m->now_us - t0 < 300000u);

    /* No answer at all to the segments: one retry, then the timeout. */
    d->dl_drop_seg = 2;
    mark = F.n_log;
    t0 = m->now_us;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, &ab, NULL, NULL), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(ab, 0);
    EF_CHECK_EQ(fk_sdo_frames(6, mark, fr, 8), 4);
    EF_CHECK(memcmp(fr[0].data, init, 8) == 0 && memcmp(fr[2].data, init, 8) == 0);
    EF_CHECK(memcmp(fr[1].data, seg0, 8) == 0 && memcmp(fr[3].data, seg0, 8) == 0);
    /* 2 x 200 ms, after 200 ms held for the last transfer's late segment answer (it was
     * retried at a segment whose answer never came: lost or late, the master cannot tell) */
    EF_CHECK(m->now_us - t0 >= 600000u && m->now_us - t0 < 700000u);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_error(m)->code, 0);

    /* A transfer under way when the master stops goes on through STOPPING into DONE (its
     * retry is sent there), and after the end the caller still has the client. */
    d->dl_drop_seg = 1;
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, big, 10), EF_OK);
    EF_CHECK_EQ(ef_comaster_stop(m), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_DONE);
    EF_CHECK(memcmp(d->dl_buf, big, 10) == 0);
    EF_CHECK_EQ(ef_comaster_error(m)->code, 0);
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    uint32_t nx = 0;
    EF_CHECK_EQ(ef_comaster_process(m, 0, &nx), EF_OK);
    EF_CHECK(nx > 0u && nx <= 200000u); /* the SDO timeout is due then */
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK(memcmp(d->dl_buf, pay, 10) == 0);
    EF_CHECK_EQ(ef_comaster_sdo_read(m, 0, EF_CO_OBJ_DEVICE_NAME, 0), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_OK);
    EF_CHECK_EQ(ef_comaster_sdo_result(m, &ab, &dp, &n), EF_OK);
    EF_CHECK(dp != NULL && n == strlen(FK_NAME) && memcmp(dp, FK_NAME, n) == 0);
    d->dl_drop_seg = 2; /* and the timeout works there too */
    EF_CHECK_EQ(ef_comaster_sdo_write(m, 1, 0x2345, 1, pay, 10), EF_OK);
    EF_CHECK_EQ(fk_sdo_wait(), EF_ERR_TIMEOUT);
    EF_CHECK_EQ(ef_comaster_state(m), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(m)->code, 0);
}

/* ------------------------------------------------------------------ integration */

static ef_canrig_t B;
static ef_comaster_t M;
static ef_codrive_t D[EF_COM_MAX_NODES];

/* Master and three real drives (nodes 1..3 homed at x 0, y 1, z 2) on the simulated bus. */
static void sim_setup(const ef_com_cfg_t *c)
{
    ef_canrig_init(&B, 0);
    EF_CHECK_EQ(ef_canrig_add_master(&B, &M, c), EF_OK);
    for (int k = 0; k < 3; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = (float)k;
        EF_CHECK_EQ(ef_canrig_add_drive(&B, &D[k], &dc), EF_OK);
    }
}

static ef_com_cfg_t sim_cfg(int mode)
{
    ef_com_cfg_t c;
    ef_comaster_cfg_default(&c, mode);
    c.n_nodes = 3;
    for (int k = 0; k < 3; k++)
        c.nodes[k] = (uint8_t)(k + 1);
    return c;
}

/* CSP reference: circle of radius 5 in x/y (period 2 s, smooth start), z ramps at 2 u/s. */
static void csp_ref(double t, float out[3])
{
    double w = 2.0 * M_PI / 2.0, T = 0.25;
    /* angle with a quadratic speed-up over T, so nothing jumps at the start */
    double a = t < T ? w * t * t / (2 * T) : w * (t - T / 2);
    out[0] = (float)(5.0 * (cos(a) - 1.0));
    out[1] = (float)(1.0 + 5.0 * sin(a));
    out[2] = (float)(2.0 + 2.0 * (t < T ? t * t / (2 * T) : t - T / 2));
}

static void t_csp(void)
{
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_NEAR(ef_comaster_node(&M, 1)->pos, 1.0, 1e-4);
    EF_CHECK(ef_comaster_name(&M, 0)[0] != 0);
    const int N = 3000; /* 3 s at 1 ms */
    static float tg[3000][3];
    int pushed = 0;
    double worst = 0;
    for (uint32_t step = 0; step < 40000 && pushed < N; step++) {
        while (pushed < N && ef_comaster_space(&M) > 0) {
            csp_ref(pushed * 1e-3, tg[pushed]);
            EF_CHECK_EQ(ef_comaster_push_target(&M, tg[pushed]), EF_OK);
            pushed++;
        }
        ef_canrig_step(&B, 100);
        /* Actual positions follow: near one of the recent targets (lag + queue). */
        if (pushed > 40) {
            double best = 1e9;
            for (int i = pushed - 40; i < pushed; i++) {
                double e = 0;
                for (int k = 0; k < 3; k++) {
                    double d = fabs(ef_codrive_position(&D[k]) - tg[i][k]);
                    e = d > e ? d : e;
                }
                best = e < best ? e : best;
            }
            worst = best > worst ? best : worst;
        }
    }
    EF_CHECK_EQ(pushed, N);
    EF_CHECK(worst < 0.2);
    EF_CHECK_EQ(M.starved, 0);
    EF_CHECK_EQ(ef_comaster_finish(&M), EF_OK);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_DONE, 2000000, 100), EF_COM_DONE);
    for (int k = 0; k < 3; k++) {
        EF_CHECK_NEAR(ef_codrive_position(&D[k]), tg[N - 1][k], 2e-3);
        EF_CHECK_NEAR(ef_comaster_node(&M, k)->pos, tg[N - 1][k], 2e-3);
        EF_CHECK(D[k].power != EF_CO_PS_OP_ENABLED);
    }
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    printf("csp: %llu frames, %llu bits, worst lag %.4f\n", (unsigned long long)B.bus.frames,
           (unsigned long long)B.bus.bits, worst);
}

/* A straight move p0 -> p1 with one constant-acceleration phase from speed v0 to v1. */
static ef_move_t mk_line(ef_vec3_t p0, ef_vec3_t p1, float v0, float v1)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 1;
    m.kind = EF_MOVE_LINE;
    m.b[0] = p0;
    m.b[1] = p1;
    double dx = p1.x - p0.x, dy = p1.y - p0.y, dz = p1.z - p0.z;
    double L = sqrt(dx * dx + dy * dy + dz * dz), T = 2 * L / (v0 + v1);
    m.length = (float)L;
    m.duration = (float)T;
    m.v_exit = v1;
    m.v_entry = v0;
    m.feed = v0 > v1 ? v0 : v1;
    m.v_max = m.feed;
    m.law.dt[0] = (float)T;
    m.law.c[0][1] = (float)(v0 / L);
    m.law.c[0][2] = (float)((v1 - v0) / (2 * T * L));
    if (v1 == 0)
        m.flags = EF_MOVE_STOP_END;
    return m;
}

#define SEG_MOVES 24
static ef_move_t SM[SEG_MOVES];

/* Three loops of a 10 x 10 square in x/y rising in z; every side accelerates to 20 u/s
 * and stops at its corner (two moves). Starts at the drives' home (0, 1, 2). */
static void seg_moves(void)
{
    ef_vec3_t p = {0, 1, 2};
    const float dx[4] = {10, 0, -10, 0}, dy[4] = {0, 10, 0, -10};
    int n = 0;
    for (int loop = 0; loop < 3; loop++)
        for (int side = 0; side < 4; side++) {
            ef_vec3_t q = {p.x + dx[side], p.y + dy[side], p.z + 0.25f};
            ef_vec3_t mid = {(p.x + q.x) / 2, (p.y + q.y) / 2, (p.z + q.z) / 2};
            SM[n++] = mk_line(p, mid, 0, 20);
            SM[n++] = mk_line(mid, q, 20, 0);
            p = q;
        }
}

/* Stream SM[0..n) in segment mode, then finish; returns the final state. */
static int seg_stream(int n, uint32_t max_us, void (*mid)(uint32_t t_us))
{
    int i = 0;
    for (uint32_t t = 0; t < max_us; t += 100) {
        while (i < n && ef_comaster_state(&M) == EF_COM_RUN && ef_comaster_space(&M) > 0) {
            EF_CHECK_EQ(ef_comaster_push_move(&M, &SM[i]), EF_OK);
            i++;
        }
        if (i == n && ef_comaster_state(&M) == EF_COM_RUN)
            EF_CHECK_EQ(ef_comaster_finish(&M), EF_OK);
        if (mid)
            mid(t);
        ef_canrig_step(&B, 100);
        int s = ef_comaster_state(&M);
        if (s == EF_COM_DONE || s == EF_COM_ERROR)
            return s;
    }
    return ef_comaster_state(&M);
}

static void seg_check_end(void)
{
    const ef_move_t *last = &SM[SEG_MOVES - 1];
    float want[3] = {last->b[1].x, last->b[1].y, last->b[1].z};
    for (int k = 0; k < 3; k++) {
        EF_CHECK_NEAR(ef_codrive_position(&D[k]), want[k], 2e-3);
        EF_CHECK_EQ(D[k].drv.done_any, SEG_MOVES);
        EF_CHECK(D[k].power != EF_CO_PS_OP_ENABLED);
    }
}

static void t_seg(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, NULL), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    seg_check_end();
    for (int k = 0; k < 3; k++) {
        EF_CHECK_EQ(D[k].seg_dups, 0);
        EF_CHECK_EQ(D[k].seg_dropped, 0);
        EF_CHECK_EQ(ef_comaster_node(&M, k)->resends, 0);
        EF_CHECK_EQ(ef_comaster_node(&M, k)->next_seq, SEG_MOVES);
    }
    printf("seg: %llu frames, %llu bits, %.1f s\n", (unsigned long long)B.bus.frames,
           (unsigned long long)B.bus.bits, (double)B.bus.now_us * 1e-6);
}

/* Distance of the three drives' commanded point from the square path of seg_moves(). */
static double seg_off_path(void)
{
    double p[3] = {D[0].drv.cmd.x, D[1].drv.cmd.x, D[2].drv.cmd.x}, best = 1e30;
    for (int i = 0; i < SEG_MOVES; i++) {
        const ef_vec3_t a = SM[i].b[0], b = SM[i].b[1];
        double ab[3] = {b.x - a.x, b.y - a.y, b.z - a.z},
               ap[3] = {p[0] - a.x, p[1] - a.y, p[2] - a.z};
        double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        double u = l2 > 0 ? (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / l2 : 0;
        u = u < 0 ? 0 : u > 1 ? 1 : u;
        double e = 0;
        for (int k = 0; k < 3; k++)
            e += (ap[k] - u * ab[k]) * (ap[k] - u * ab[k]);
        best = sqrt(e) < best ? sqrt(e) : best;
    }
    return best;
}

/* Feed hold mid-side at 20 units/s (t 1.25 .. 2.25 s): every drive got the halt bit in the same
 * SYNC, so the three axes decelerate together and stand on the path; the master keeps streaming
 * into the rings meanwhile; the resume completes every segment once and ends at the path's end. */
static double sh_off;
static int sh_held, sh_stood;
static float sh_at[3];
static void seg_hold_mid(uint32_t t)
{
    double e = seg_off_path();
    sh_off = e > sh_off ? e : sh_off;
    if (t == 1250000)
        EF_CHECK_EQ(ef_comaster_hold(&M, 1), EF_OK);
    if (t == 2250000)
        EF_CHECK_EQ(ef_comaster_hold(&M, 0), EF_OK);
    int all = D[0].drv.held && D[1].drv.held && D[2].drv.held;
    if (t > 1550000 && t < 2250000) {
        if (!sh_held)
            for (int k = 0; k < 3; k++)
                sh_at[k] = D[k].drv.cmd.x;
        sh_held += all;
        for (int k = 0; k < 3; k++)
            sh_stood &= D[k].drv.cmd.x == sh_at[k];
    }
}

static void t_seg_hold(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    EF_CHECK_EQ(ef_comaster_hold(NULL, 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    uint64_t t0 = B.bus.now_us;
    sh_off = 0;
    sh_held = 0;
    sh_stood = 1;
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, seg_hold_mid), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    seg_check_end();
    EF_CHECK_EQ(sh_held, 6999); /* every 100 us step from 1.55 to 2.25 s: all three held */
    EF_CHECK(sh_stood);
    EF_CHECK_NEAR(sh_off, 0, 1e-3);
    for (int k = 0; k < 3; k++) {
        EF_CHECK_EQ(D[k].seg_dups, 0);
        EF_CHECK_EQ(D[k].seg_dropped, 0);
        EF_CHECK(D[k].drv.fault == EF_DRV_FAULT_NONE);
    }
    /* The stream took the path's time plus the second held (less the ramps' half). */
    double path_t = 0;
    for (int i = 0; i < SEG_MOVES; i++)
        path_t += SM[i].duration;
    double took = (double)(B.bus.now_us - t0) * 1e-6;
    printf("seg_hold: off the path at most %.2g mm, stood at (%.3f %.3f %.3f), %.2f s for a "
           "%.2f s path\n",
           sh_off, (double)sh_at[0], (double)sh_at[1], (double)sh_at[2], took, path_t);
    EF_CHECK(took > path_t + 0.9);
    /* CSP has no halt: the caller slows the targets. */
    c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_comaster_hold(&M, 1), EF_ERR_ARG);
}

/* Drop hook: lose the second (last) chunk on RPDO2 of node 2 of the record with sequence bits 5
 * (once), and the first law chunk of sequence 9 (once). */
/* A chunk's header byte: the sequence number's low bits and the chunk index. */
#define CHUNK_HDR(seq, k)                                                                          \
    ((uint8_t)((((seq)&EF_CO_CHUNK_SEQ_MASK) << EF_CO_CHUNK_INDEX_BITS) | (k)))

static int drop_state;
static int drop_some(void *ctx, const ef_can_frame_t *f, int src, uint64_t n)
{
    (void)ctx;
    (void)src;
    (void)n;
    if (!(drop_state & 1) && f->id == EF_CO_COB_RPDO2 + 2 && f->data[0] == CHUNK_HDR(5, 1)) {
        drop_state |= 1;
        return 1;
    }
    if (!(drop_state & 2) && f->id == EF_CO_LAW_COBID && f->data[0] == CHUNK_HDR(9, 0)) {
        drop_state |= 2;
        return 1;
    }
    return 0;
}

static void t_gobackn(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    drop_state = 0;
    B.bus.drop = drop_some;
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, NULL), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    EF_CHECK_EQ(drop_state, 3);
    EF_CHECK(B.bus.dropped == 2);
    seg_check_end();
    EF_CHECK(ef_comaster_node(&M, 1)->resends >= 1);
    EF_CHECK(D[1].seg_dropped >= 1);
    EF_CHECK(M.resends >= 1); /* both losses fall in one go-back-N window */
}

/* The port says it still holds frames (a slow USB adapter) for the first 200 ms of the
 * stream: go-back-N waits though node 2 lost a chunk (what was sent may not have left);
 * once the port is empty it resends as before, and every segment arrives once. */
static uint32_t gp_resends_held;
static void gp_mid(uint32_t t)
{
    EF_CHECK_EQ(ef_comaster_tx_pending(&M, t < 200000 ? 5u : 0u), EF_OK);
    if (t == 199900)
        gp_resends_held = M.resends + (drop_state & 1 ? 0u : 1000u); /* the loss came first */
}

static void t_gobackn_pending(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    drop_state = 0;
    B.bus.drop = drop_some;
    EF_CHECK_EQ(ef_comaster_tx_pending(NULL, 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    gp_resends_held = 99;
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, gp_mid), EF_COM_DONE);
    EF_CHECK_EQ(gp_resends_held, 0);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    EF_CHECK_EQ(drop_state, 3);
    seg_check_end();
    EF_CHECK(M.resends >= 1);
}

/* Drop hook: chunk 0 of the axis records of segments 8, 11, 14, 17 and 20 to node 2, the
 * first time each is sent (its bytes 1..2 are the record's sequence number): five losses
 * far enough apart to need five go-back-N rounds, each of which recovers. */
static uint32_t drop_seen;
static int drop_spread(void *ctx, const ef_can_frame_t *f, int src, uint64_t n)
{
    (void)ctx;
    (void)src;
    (void)n;
    if (f->id != EF_CO_COB_RPDO2 + 2 || (f->data[0] & EF_CO_CHUNK_INDEX_MASK) != 0)
        return 0;
    uint32_t seq = ef_co_get16(&f->data[1]);
    if (seq < 8 || seq > 20 || (seq - 8) % 3 != 0 || (drop_seen & (1u << seq)))
        return 0;
    drop_seen |= 1u << seq;
    return 1;
}

/* Drop hook: every axis chunk to node 2 from sequence bits 3 on (a node that never gets
 * its records). */
static int drop_all(void *ctx, const ef_can_frame_t *f, int src, uint64_t n)
{
    (void)ctx;
    (void)src;
    (void)n;
    return f->id == EF_CO_COB_RPDO2 + 2 && (f->data[0] >> EF_CO_CHUNK_INDEX_BITS) >= 3;
}

/* Go-back-N gives up only after max_resends rounds in a row without progress: many
 * recovered losses in one program are fine; a node that never advances is an error. */
static void t_resend_limit(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    c.max_resends = 1;
    sim_setup(&c);
    drop_seen = 0;
    B.bus.drop = drop_spread;
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, NULL), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    seg_check_end();
    printf("resend limit: %llu chunks lost, %u go-back-N rounds in all (limit 1 in a row)\n",
           (unsigned long long)B.bus.dropped, M.resends);
    EF_CHECK_EQ(B.bus.dropped, 5);
    EF_CHECK(M.resends > 1);

    seg_moves();
    c = sim_cfg(EF_COM_MODE_SEGMENT);
    c.max_resends = 3;
    sim_setup(&c);
    B.bus.drop = drop_all;
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, NULL), EF_COM_ERROR);
    const ef_com_error_t *e = ef_comaster_error(&M);
    EF_CHECK_EQ(e->code, EF_ERR_PROTO);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_STREAM);
    EF_CHECK_EQ(e->value, 3); /* the oldest segment node 2 never got */
    EF_CHECK_EQ(M.resends, 4);
}

static void emcy_mid(uint32_t t)
{
    if (t == 2000000)
        ef_codrive_fault(&D[1], EF_DRV_FAULT_INJECTED);
}

static void t_emcy(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    EF_CHECK_EQ(seg_stream(SEG_MOVES, 30000000, emcy_mid), EF_COM_ERROR);
    const ef_com_error_t *e = ef_comaster_error(&M);
    EF_CHECK_EQ(e->code, EF_ERR_DRIVE);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_EMCY);
    EF_CHECK_EQ(e->node, 2);
    EF_CHECK_EQ(e->emcy, ef_co_emcy_of_fault(EF_DRV_FAULT_INJECTED));
    EF_CHECK_EQ(e->drive_fault, EF_DRV_FAULT_INJECTED);
    for (int k = 0; k < 3; k++) {
        EF_CHECK(D[k].power != EF_CO_PS_OP_ENABLED);
        EF_CHECK(D[k].drv.state != EF_DRV_RUNNING && D[k].drv.state != EF_DRV_STOPPING);
        EF_CHECK_NEAR(D[k].drv.act_vel.x, 0.0, 0.05);
        EF_CHECK(D[k].drv.done_any < SEG_MOVES);
    }
    EF_CHECK_EQ(D[1].power, EF_CO_PS_FAULT);
    EF_CHECK(D[0].power != EF_CO_PS_FAULT);
    /* stopped soon after the fault, not at the end of the program */
    EF_CHECK(B.bus.now_us < 3000000u + 3000000u);
}

static void sim_all_stopped_by_master(const char *what);

static void t_heartbeat(void)
{
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    uint64_t t0 = 0;
    int i = 0;
    for (uint32_t step = 0; step < 30000; step++) {
        while (ef_comaster_state(&M) == EF_COM_RUN && ef_comaster_space(&M) > 0) {
            float p[3];
            csp_ref(i++ * 1e-3, p);
            ef_comaster_push_target(&M, p);
        }
        if (step == 5000) {
            ef_codrive_heartbeat_off(&D[2], 1);
            t0 = B.bus.now_us;
        }
        ef_canrig_step(&B, 100);
        if (ef_comaster_state(&M) == EF_COM_ERROR)
            break;
    }
    const ef_com_error_t *e = ef_comaster_error(&M);
    EF_CHECK_EQ(ef_comaster_state(&M), EF_COM_ERROR);
    EF_CHECK_EQ(e->code, EF_ERR_HEARTBEAT);
    EF_CHECK_EQ(e->what, EF_COM_WHAT_HEARTBEAT);
    EF_CHECK_EQ(e->node, 3);
    EF_CHECK(t0 > 0);
    /* node 3 only stopped sending heartbeats: it is reachable and must be stopped by the
     * master like the others, not left to its SYNC-loss watchdog when SYNC ends */
    sim_all_stopped_by_master("heartbeat");
}

/* Every drive stopped under the master's control: at rest and out of OPERATION ENABLED
 * while SYNC still ran (not by its own SYNC-loss watchdog). */
static void sim_all_stopped_by_master(const char *what)
{
    for (int k = 0; k < 3; k++) {
        if (D[k].power == EF_CO_PS_OP_ENABLED || D[k].drv.state == EF_DRV_RUNNING ||
            D[k].drv.state == EF_DRV_STOPPING || D[k].last_fault == EF_DRV_FAULT_WATCHDOG) {
            ef_t_fail++;
            fprintf(stderr, "%s: node %d left in power state %d, drive state %d, fault %d\n", what,
                    k + 1, D[k].power, D[k].drv.state, D[k].last_fault);
        } else {
            ef_t_pass++;
        }
        EF_CHECK_NEAR(D[k].drv.cmd_vel.x, 0.0, 1e-3); /* commanded to rest */
    }
}

/* Push CSP targets while running and step the rig by step_us for us. */
static void sim_csp_run(uint32_t us, uint32_t step_us, int *i)
{
    for (uint32_t t = 0; t < us; t += step_us) {
        while (ef_comaster_state(&M) == EF_COM_RUN && ef_comaster_space(&M) > 0) {
            float p[3];
            csp_ref((*i)++ * 1e-3, p);
            ef_comaster_push_target(&M, p);
        }
        ef_canrig_step(&B, step_us);
    }
}

/* A starved master (its process not scheduled for 300 ms, as on a loaded host): the drives'
 * heartbeats queue at its port. Read after the gap they prove the nodes alive; only a node
 * that sent none in the gap is lost. */
static void t_starved(void)
{
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    int i = 0;
    sim_csp_run(200000, 100, &i);
    B.hold_master = 1;
    ef_canrig_run(&B, 300000, 100);
    B.hold_master = 0;
    sim_csp_run(100000, 100, &i);
    EF_CHECK_EQ(ef_comaster_state(&M), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    /* the same gap with node 2 silent in it: lost, and every drive stopped */
    B.hold_master = 1;
    ef_codrive_heartbeat_off(&D[1], 1);
    ef_canrig_run(&B, 300000, 100);
    B.hold_master = 0;
    ef_canrig_step(&B, 100);
    const ef_com_error_t *e = ef_comaster_error(&M);
    EF_CHECK_EQ(e->code, EF_ERR_HEARTBEAT);
    EF_CHECK_EQ(e->node, 2);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_ERROR, 6000000, 100), EF_COM_ERROR);
    sim_all_stopped_by_master("starved");
}

/* Every heartbeat stops at once while the nodes are alive (their producers broken, or the
 * heartbeats lost on the way): all are lost together, and the master must still stop them
 * all while SYNC runs, since it cannot know they are gone. */
static void t_heartbeat_all(void)
{
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    int i = 0;
    sim_csp_run(300000, 100, &i);
    for (int k = 0; k < 3; k++)
        ef_codrive_heartbeat_off(&D[k], 1);
    for (int s = 0; s < 100000 && ef_comaster_state(&M) == EF_COM_RUN; s++)
        sim_csp_run(100, 100, &i);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, EF_ERR_HEARTBEAT);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_ERROR, 6000000, 100), EF_COM_ERROR);
    sim_all_stopped_by_master("heartbeat_all");
}

/* A node that dies mid-path (no frame at all from then on): lost after hb_timeout_ms, the
 * others stopped by the master, which does not wait for the dead one beyond a few SYNCs. */
static void t_node_dead(void)
{
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_CSP);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    int i = 0;
    sim_csp_run(300000, 100, &i);
    B.hold_drives = 1u << 2;
    uint64_t t0 = B.bus.now_us;
    for (int s = 0; s < 100000 && ef_comaster_state(&M) == EF_COM_RUN; s++)
        sim_csp_run(100, 100, &i);
    const ef_com_error_t *e = ef_comaster_error(&M);
    EF_CHECK_EQ(e->code, EF_ERR_HEARTBEAT);
    EF_CHECK_EQ(e->node, 3);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_ERROR, 6000000, 100), EF_COM_ERROR);
    /* lost within the timeout (+ a heartbeat period), stopped within the ramp after it */
    uint64_t dt = B.bus.now_us - t0;
    printf("dead node: lost and the others stopped %.0f ms after its last frame\n", dt / 1e3);
    EF_CHECK(dt < (uint64_t)(c.hb_timeout_ms + 100 + 1500) * 1000u);
    for (int k = 0; k < 2; k++) {
        EF_CHECK(D[k].power != EF_CO_PS_OP_ENABLED && D[k].power != EF_CO_PS_QUICK_STOP);
        EF_CHECK(D[k].last_fault != EF_DRV_FAULT_WATCHDOG);
        EF_CHECK_NEAR(D[k].drv.cmd_vel.x, 0.0, 1e-3);
    }
    B.hold_drives = 0;
}

/* Step the bus until the caller's SDO transfer is no longer pending; its result. */
static int sim_sdo_wait(void)
{
    int rc = ef_comaster_sdo_result(&M, NULL, NULL, NULL);
    for (int i = 0; i < 20000 && rc == EF_ERR_AGAIN; i++) {
        ef_canrig_step(&B, 100);
        rc = ef_comaster_sdo_result(&M, NULL, NULL, NULL);
    }
    return rc;
}

/* Read index:sub of node k through the caller's API; returns the result, data in out/len. */
static int sim_sdo_read(int k, uint16_t index, uint8_t sub, uint8_t *out, uint32_t *len)
{
    *len = 0;
    EF_CHECK_EQ(ef_comaster_sdo_read(&M, k, index, sub), EF_OK);
    int rc = sim_sdo_wait();
    const uint8_t *p = NULL;
    uint32_t n = 0;
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, NULL, &p, &n), rc);
    if (rc == EF_OK && p && n <= EF_COM_SDO_BUF) {
        memcpy(out, p, n);
        *len = n;
    }
    return rc;
}

/* The caller's SDO client against real drives in segment mode: an axis record delivered over
 * SDO by segmented download (0x2100), expedited and segmented reads, aborts, a call while a
 * transfer is pending; transfers during motion leave the stream alone; one after DONE. */
static void t_sdo_user(void)
{
    seg_moves();
    ef_com_cfg_t c = sim_cfg(EF_COM_MODE_SEGMENT);
    sim_setup(&c);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    /* The axis record of the first move (sequence 0, x) in its two 8-byte chunks: the drive
     * takes 0x2100 chunks over SDO as by RPDO2. */
    ef_move_t mv = SM[0];
    mv.seq = 0;
    uint8_t rec[EF_CO_REC_MAX], ch[8];
    uint32_t rlen = 0;
    EF_CHECK_EQ(ef_co_axis_encode(&mv, 0, rec, &rlen), EF_OK);
    EF_CHECK_EQ(ef_co_chunk_count(rlen), 2);
    ef_co_chunk(rec, rlen, 0, ch);
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 0, EF_CO_OBJ_SEG_AXIS, 0, ch, 8), EF_OK);
    EF_CHECK_EQ(sim_sdo_wait(), EF_OK);
    EF_CHECK_EQ(D[0].asm_axis.len, rlen); /* record under way, chunk 1 expected */
    EF_CHECK_EQ(D[0].asm_axis.next, 1);
    ef_co_chunk(rec, rlen, 1, ch);
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 0, EF_CO_OBJ_SEG_AXIS, 0, ch, 8), EF_OK);
    EF_CHECK_EQ(sim_sdo_wait(), EF_OK);
    EF_CHECK_EQ(D[0].have_axis, 1); /* complete: waits for its law record */
    EF_CHECK_EQ(D[0].axis_seq16, 0);
    EF_CHECK_EQ(D[0].seg_dropped, 0);

    /* Expedited read; calls while it is pending are refused. */
    EF_CHECK_EQ(ef_comaster_sdo_read(&M, 1, EF_CO_OBJ_DEVICE_TYPE, 0), EF_OK);
    EF_CHECK_EQ(ef_comaster_sdo_read(&M, 1, EF_CO_OBJ_DEVICE_TYPE, 0), EF_ERR_STATE);
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 0, EF_CO_OBJ_SEG_AXIS, 0, ch, 8), EF_ERR_STATE);
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, NULL, NULL, NULL), EF_ERR_AGAIN);
    EF_CHECK_EQ(sim_sdo_wait(), EF_OK);
    const uint8_t *p = NULL;
    uint32_t n = 0, ab = 1;
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, &ab, &p, &n), EF_OK);
    EF_CHECK_EQ(ab, 0);
    EF_CHECK(p != NULL && n == 4);
    if (p && n == 4)
        EF_CHECK_EQ(ef_co_get32(p), 0x00020192u);
    /* Segmented read: the device name. */
    uint8_t buf[EF_COM_SDO_BUF];
    EF_CHECK_EQ(sim_sdo_read(2, EF_CO_OBJ_DEVICE_NAME, 0, buf, &n), EF_OK);
    EF_CHECK(n == 18 && memcmp(buf, "evenfeed sim drive", 18) == 0);
    /* Writes to a read-only object, expedited and segmented: the drive's abort, nothing else. */
    const uint8_t four[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 0, EF_CO_OBJ_DEVICE_TYPE, 0, four, 4), EF_OK);
    EF_CHECK_EQ(sim_sdo_wait(), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, &ab, &p, &n), EF_ERR_PROTO);
    EF_CHECK_EQ(ab, 0x06010002u);
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 2, EF_CO_OBJ_DEVICE_NAME, 0, four, 8), EF_OK);
    EF_CHECK_EQ(sim_sdo_wait(), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, &ab, NULL, NULL), EF_ERR_PROTO);
    EF_CHECK_EQ(ab, EF_CO_ABORT_READONLY);
    EF_CHECK_EQ(ef_comaster_state(&M), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);

    /* Stream every move; during motion an abort and a statusword read change nothing. */
    for (int i = 0; i < SEG_MOVES; i++)
        EF_CHECK_EQ(ef_comaster_push_move(&M, &SM[i]), EF_OK);
    ef_canrig_run(&B, 1000000, 100);
    EF_CHECK_EQ(ef_comaster_state(&M), EF_COM_RUN);
    EF_CHECK(M.running);
    EF_CHECK(D[0].drv.done_any >= 1);
    EF_CHECK_EQ(ef_comaster_sdo_write(&M, 1, EF_CO_OBJ_DEVICE_TYPE, 0, four, 4), EF_OK);
    EF_CHECK_EQ(sim_sdo_wait(), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_comaster_sdo_result(&M, &ab, NULL, NULL), EF_ERR_PROTO);
    EF_CHECK_EQ(ab, EF_CO_ABORT_READONLY);
    EF_CHECK_EQ(sim_sdo_read(1, EF_CO_OBJ_STATUSWORD, 0, buf, &n), EF_OK);
    EF_CHECK_EQ(n, 2);
    EF_CHECK_EQ(ef_co_get16(buf) & 0x6Fu, 0x27u); /* operation enabled */
    EF_CHECK_EQ(ef_comaster_state(&M), EF_COM_RUN);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    EF_CHECK_EQ(ef_comaster_finish(&M), EF_OK);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_DONE, 30000000, 100), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    seg_check_end();
    for (int k = 0; k < 3; k++) {
        EF_CHECK_EQ(D[k].seg_dups, 0);
        EF_CHECK_EQ(D[k].seg_dropped, 0);
        EF_CHECK_EQ(ef_comaster_node(&M, k)->resends, 0);
    }
    /* After the end: still usable. */
    EF_CHECK_EQ(sim_sdo_read(0, EF_CO_OBJ_DEVICE_TYPE, 0, buf, &n), EF_OK);
    EF_CHECK(n == 4 && ef_co_get32(buf) == 0x00020192u);
}

/* ------------------------------------------------------------- nine axes: one drive each */

#define AX_NODES 5 /* X Y Z A B */
#define AX_MOVES 400
static ef_move_t AM[AX_MOVES];
static int AN;
static float ax_end[AX_NODES];

/* Master and AX_NODES real drives (x 0, y 1, z 2, A and B at 0) on the simulated bus. */
static void ax_setup(int mode)
{
    ef_com_cfg_t c;
    ef_comaster_cfg_default(&c, mode);
    c.n_nodes = AX_NODES;
    for (int k = 0; k < AX_NODES; k++)
        c.nodes[k] = (uint8_t)(k + 1);
    ef_canrig_init(&B, 0);
    EF_CHECK_EQ(ef_canrig_add_master(&B, &M, &c), EF_OK);
    for (int k = 0; k < AX_NODES; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = k < 3 ? (float)k : 0.0f;
        EF_CHECK_EQ(ef_canrig_add_drive(&B, &D[k], &dc), EF_OK);
    }
}

/* A zigzag in x/y from the drives' home, A and B changing their rates at every corner,
 * through the smoother (A B as its auxiliary axes, 90 deg/s and 900 deg/s^2). */
static void ax_moves(void)
{
    static ef_smooth_t s;
    ef_smooth_cfg_t c;
    memset(&c, 0, sizeof c);
    c.g2 = &ef_tbl_g2_default;
    for (int i = 0; i < 3; i++) {
        c.lim.v_axis[i] = 100.0f;
        c.lim.a_axis[i] = 1000.0f;
    }
    for (int k = 0; k < 2; k++) {
        c.lim.v_axis[3 + k] = 90.0f;
        c.lim.a_axis[3 + k] = 900.0f;
        c.aux_tol[k] = 0.2f;
    }
    c.lim.j_max = 20000.0f;
    c.lim.a_normal_frac = 0.5f;
    c.smooth_degree = 5;
    c.keep_slow_blends = 1;
    c.naux = 2;
    EF_CHECK_EQ(ef_smooth_init(&s, &c, ef_v3(0, 1, 2)), EF_OK);
    AN = 0;
    for (int i = 0; i < 8; i++) {
        ef_prim_t p;
        memset(&p, 0, sizeof p);
        p.kind = EF_PRIM_LINE;
        p.end = ef_v3(5.0f * (float)(i + 1), (i & 1) ? 1.0f : 3.0f, 2.0f);
        p.feed = 20.0f;
        p.tol = 0.05f;
        p.aux[0] = 15.0f * (float)((i * 7) % 5);
        p.aux[1] = -10.0f * (float)(i % 3);
        if (i == 8 - 1) { /* end values for the check */
            ax_end[0] = p.end.x, ax_end[1] = p.end.y, ax_end[2] = p.end.z;
            ax_end[3] = p.aux[0], ax_end[4] = p.aux[1];
        }
        int rc = ef_smooth_push(&s, &p);
        for (int g = 0; rc == EF_ERR_FULL && g < 10000; g++) {
            while (AN < AX_MOVES && ef_smooth_pull(&s, &AM[AN]) == EF_OK)
                AN++;
            rc = ef_smooth_push(&s, &p);
        }
        EF_CHECK_EQ(rc, EF_OK);
    }
    int rc = EF_ERR_FULL;
    for (int g = 0; rc == EF_ERR_FULL && g < 100000; g++) {
        rc = ef_smooth_finish(&s);
        while (AN < AX_MOVES && ef_smooth_pull(&s, &AM[AN]) == EF_OK)
            AN++;
    }
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK(ef_smooth_stats(&s).blends >= 5);
}

/* Segment mode with five drives: each gets its axis's record (A and B the moves' ab), every
 * segment executed once on every drive, A and B within their speed limit at the drives,
 * every axis at its programmed end. */
static void t_seg_axes(void)
{
    ax_moves();
    ax_setup(EF_COM_MODE_SEGMENT);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    int i = 0, s = EF_COM_RUN;
    double vmax[AX_NODES] = {0};
    for (uint32_t t = 0; t < 60000000u; t += 100) {
        while (i < AN && ef_comaster_state(&M) == EF_COM_RUN && ef_comaster_space(&M) > 0) {
            EF_CHECK_EQ(ef_comaster_push_move(&M, &AM[i]), EF_OK);
            i++;
        }
        if (i == AN && ef_comaster_state(&M) == EF_COM_RUN)
            EF_CHECK_EQ(ef_comaster_finish(&M), EF_OK);
        ef_canrig_step(&B, 100);
        for (int k = 0; k < AX_NODES; k++) /* the drives' own commanded speed */
            vmax[k] = fmax(vmax[k], fabs((double)D[k].drv.cmd_vel.x));
        s = ef_comaster_state(&M);
        if (s == EF_COM_DONE || s == EF_COM_ERROR)
            break;
    }
    EF_CHECK_EQ(s, EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    for (int k = 0; k < AX_NODES; k++) {
        EF_CHECK_NEAR(ef_codrive_position(&D[k]), ax_end[k], 2e-3);
        EF_CHECK_EQ(D[k].drv.done_any, (uint32_t)AN);
        EF_CHECK_EQ(D[k].seg_dups, 0);
        EF_CHECK_EQ(D[k].seg_dropped, 0);
    }
    EF_CHECK(vmax[3] > 10.0 && vmax[3] <= 90.0 * 1.03);
    EF_CHECK(vmax[4] > 5.0 && vmax[4] <= 90.0 * 1.03);
    printf("seg_axes: %d segments to 5 drives, %llu frames, %.1f s; peak speeds x %.1f y %.1f "
           "A %.1f B %.1f (deg/s, limit 90)\n",
           AN, (unsigned long long)B.bus.frames, (double)B.bus.now_us * 1e-6, vmax[0], vmax[1],
           vmax[3], vmax[4]);
}

/* CSP with five drives: the host interpolator's setpoints (A and B from ef_setpoint_t::aux)
 * as targets; the drives follow and end at every programmed value. */
static void t_csp_axes(void)
{
    ax_moves();
    ax_setup(EF_COM_MODE_CSP);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_RUN, 3000000, 100), EF_COM_RUN);
    static ef_interp_t ip;
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 1, 2), 1000, EF_STEP_CORRECTED), EF_OK);
    int i = 0, targets = 0, idle = 0;
    double worst = 0;
    static float hist[64][AX_NODES];
    for (uint32_t step = 0; step < 200000 && idle < 50; step++) {
        while (ef_comaster_space(&M) > 0 && idle < 50) {
            while (i < AN && ef_interp_space(&ip) > 0)
                EF_CHECK_EQ(ef_interp_push(&ip, &AM[i++]), EF_OK);
            ef_setpoint_t sp;
            EF_CHECK_EQ(ef_interp_process(&ip, 1000, NULL, &sp), EF_OK);
            float pos[EF_COM_MAX_NODES] = {sp.p.x, sp.p.y, sp.p.z, sp.aux[0], sp.aux[1]};
            EF_CHECK_EQ(ef_comaster_push_target(&M, pos), EF_OK);
            memcpy(hist[targets % 64], pos, sizeof hist[0]);
            targets++;
            idle = i == AN && !sp.moving ? idle + 1 : 0;
        }
        ef_canrig_step(&B, 100);
        if (targets > 64) { /* every drive near one of the recent targets (lag + queue) */
            double best = 1e9;
            for (int j = 0; j < 64; j++) {
                double e = 0;
                for (int k = 0; k < AX_NODES; k++)
                    e = fmax(e, fabs(ef_codrive_position(&D[k]) - hist[j][k]));
                best = fmin(best, e);
            }
            worst = fmax(worst, best);
        }
    }
    EF_CHECK_EQ(ef_comaster_finish(&M), EF_OK);
    EF_CHECK_EQ(ef_canrig_run_until(&B, EF_COM_DONE, 3000000, 100), EF_COM_DONE);
    EF_CHECK_EQ(ef_comaster_error(&M)->code, 0);
    EF_CHECK(worst < 0.2);
    for (int k = 0; k < AX_NODES; k++)
        EF_CHECK_NEAR(ef_codrive_position(&D[k]), ax_end[k], 2e-3);
    printf("csp_axes: %d targets to 5 drives, worst lag %.4f (units or deg)\n", targets, worst);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"args", t_args},
        {"fake_csp", t_fake_csp},
        {"fake_seg", t_fake_seg},
        {"boot", t_boot},
        {"abort", t_abort},
        {"devtype", t_devtype},
        {"sdo_timeout", t_sdo_timeout},
        {"malformed", t_malformed},
        {"fault", t_fault},
        {"again", t_again},
        {"bus", t_bus},
        {"csp", t_csp},
        {"seg", t_seg},
        {"seg_axes", t_seg_axes},
        {"csp_axes", t_csp_axes},
        {"seg_hold", t_seg_hold},
        {"gobackn", t_gobackn},
        {"gobackn_pending", t_gobackn_pending},
        {"resend_limit", t_resend_limit},
        {"emcy", t_emcy},
        {"heartbeat", t_heartbeat},
        {"starved", t_starved},
        {"heartbeat_all", t_heartbeat_all},
        {"node_dead", t_node_dead},
        {"sdo_segdl_fake", t_sdo_segdl_fake},
        {"sdo_user", t_sdo_user},
        {"sdo_client", t_sdo_client},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
