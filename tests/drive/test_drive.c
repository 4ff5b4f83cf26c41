/* SPDX-License-Identifier: Apache-2.0 */
/* Drive side tests: CRC and slot codec (ef_modbus), the drive executing streamed segments
 * with its servo model (ef_drive), controlled stops and faults, and the Modbus register
 * device. Expected positions come from an independent double-precision evaluation of the
 * Bézier curves and time laws built here. */
#include <stdint.h>
#include <string.h>
#include "ef_test.h"
#include "ef_testmove.h"
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/modbus/ef_modbus.h"

#define PERIOD_US 1000u
#define V0        50.0f /* cruise speed of the test chains (units/s) */

/* ------------------------------------------------------------------ helpers */

/* A move through pts[0..deg] with a one-phase law at V0 (ef_testmove.h). */
static ef_move_t mk_move(uint32_t seq, int deg, const ef_vec3_t *pts, int law)
{
    return tm_move(seq, deg, pts, law, V0);
}

/* A straight move from a to b. */
static ef_move_t mk_line(uint32_t seq, ef_vec3_t a, ef_vec3_t b, int law)
{
    ef_vec3_t p[2] = {a, b};
    return mk_move(seq, 1, p, law);
}

static double dist3(ef_vec3_t a, const double b[3])
{
    double dx = a.x - b[0], dy = a.y - b[1], dz = a.z - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

static double vlen(ef_vec3_t a)
{
    return sqrt((double)a.x * a.x + (double)a.y * a.y + (double)a.z * a.z);
}

/* The five-move chain: accelerate, cruise, cubic S-bend, quintic climb, decelerate. */
static int mk_chain(ef_move_t *mv)
{
    ef_vec3_t p0[2] = {ef_v3(0, 0, 0), ef_v3(10, 0, 0)};
    ef_vec3_t p1[2] = {ef_v3(10, 0, 0), ef_v3(20, 0, 0)};
    ef_vec3_t p2[4] = {ef_v3(20, 0, 0), ef_v3(23.5f, 0, 0), ef_v3(26.5f, 5, 0), ef_v3(30, 5, 0)};
    ef_vec3_t p3[6] = {ef_v3(30, 5, 0),    ef_v3(32, 5, 0),    ef_v3(34, 5, 0.5f),
                       ef_v3(36, 5, 1.5f), ef_v3(38, 5, 2.0f), ef_v3(40, 5, 2.0f)};
    ef_vec3_t p4[2] = {ef_v3(40, 5, 2), ef_v3(50, 5, 2)};
    mv[0] = mk_move(0, 1, p0, LAW_ACCEL);
    mv[1] = mk_move(1, 1, p1, LAW_CRUISE);
    mv[2] = mk_move(2, 3, p2, LAW_CRUISE);
    mv[3] = mk_move(3, 5, p3, LAW_CRUISE);
    mv[4] = mk_move(4, 1, p4, LAW_DECEL);
    return 5;
}

static ef_drive_t g_d; /* large: keep it off the stack */

/* A drive ENABLED at the origin with default servo parameters. */
static void drive_up(ef_drive_t *d, const ef_servo_cfg_t *cfg)
{
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    if (cfg)
        c = *cfg;
    EF_CHECK_EQ(ef_drive_init(d, &c, ef_v3(0, 0, 0), PERIOD_US), EF_OK);
    EF_CHECK_EQ(ef_drive_enable(d, 1), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_ENABLED);
}

/* ------------------------------------------------------------------ codec */

static void test_crc(void)
{
    const char *s = "123456789";
    EF_CHECK_EQ(ef_crc16_modbus((const uint8_t *)s, 9), 0x4B37);
    EF_CHECK_EQ(ef_crc16_modbus(NULL, 3), 0xFFFF);
    EF_CHECK_EQ(ef_crc16_modbus((const uint8_t *)s, 0), 0xFFFF);
    /* Word CRC = byte CRC over the words sent high byte first. */
    uint16_t w[5] = {0x1234, 0xABCD, 0x0001, 0xFF00, 0x8000};
    uint8_t b[10];
    for (int i = 0; i < 5; i++) {
        b[2 * i] = (uint8_t)(w[i] >> 8);
        b[2 * i + 1] = (uint8_t)w[i];
    }
    EF_CHECK_EQ(ef_mb_crc_words(w, 5), ef_crc16_modbus(b, 10));
    /* A standard Modbus RTU frame: 01 03 00 00 00 0A has CRC C5CD (sent CD C5). */
    const uint8_t fr[6] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x0A};
    EF_CHECK_EQ(ef_crc16_modbus(fr, 6), 0xCDC5);
    uint16_t r[2];
    ef_mb_put_u32(r, 0xDEADBEEFu);
    EF_CHECK_EQ(r[0], 0xDEAD);
    EF_CHECK_EQ(r[1], 0xBEEF);
    EF_CHECK_EQ(ef_mb_get_u32(r), 0xDEADBEEFu);
    ef_mb_put_f32(r, 1.0f);
    EF_CHECK_EQ(r[0], 0x3F80);
    EF_CHECK_EQ(r[1], 0x0000);
    ef_mb_put_f32(r, -2.5f);
    EF_CHECK(ef_mb_get_f32(r) == -2.5f);
}

static uint32_t fbits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

/* A random move with every used field set (not necessarily a sensible curve). */
static ef_move_t rnd_move(unsigned long long *rs)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    static const int degs[3] = {1, 3, 5};
    m.degree = (uint8_t)degs[ef_t_rng(rs) % 3];
    m.seq = (uint32_t)ef_t_rng(rs);
    m.flags = (ef_t_rng(rs) & 1) ? EF_MOVE_STOP_END : 0;
    m.duration = (float)ef_t_uniform(rs, 1e-4, 10);
    m.length = (float)ef_t_uniform(rs, 1e-3, 1000);
    m.v_exit = (float)ef_t_uniform(rs, 0, 500);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        m.law.dt[k] = (float)ef_t_uniform(rs, 0, 3);
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            m.law.c[k][i] = (float)ef_t_uniform(rs, -1e4, 1e4);
    }
    for (int i = 0; i <= m.degree; i++)
        m.b[i] = ef_v3((float)ef_t_uniform(rs, -1e5, 1e5), (float)ef_t_uniform(rs, -1, 1),
                       (float)ef_t_uniform(rs, -1e-30, 1e-30));
    return m;
}

/* Whether two moves agree bit for bit in every field a slot carries. */
static int same_move(const ef_move_t *a, const ef_move_t *b)
{
    int ok = a->degree == b->degree && a->seq == b->seq && a->flags == b->flags &&
             fbits(a->duration) == fbits(b->duration) && fbits(a->length) == fbits(b->length) &&
             fbits(a->v_exit) == fbits(b->v_exit);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        ok &= fbits(a->law.dt[k]) == fbits(b->law.dt[k]);
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            ok &= fbits(a->law.c[k][i]) == fbits(b->law.c[k][i]);
    }
    for (int i = 0; i <= a->degree; i++)
        ok &= fbits(a->b[i].x) == fbits(b->b[i].x) && fbits(a->b[i].y) == fbits(b->b[i].y) &&
              fbits(a->b[i].z) == fbits(b->b[i].z);
    return ok;
}

static void test_codec(void)
{
    unsigned long long rs = 12345;
    uint16_t w[EF_MB_SLOT_WORDS];
    int all_ok = 1, unused_zero = 1;
    for (int it = 0; it < 2000; it++) {
        ef_move_t m = rnd_move(&rs), r;
        memset(&r, 0xA5, sizeof r);
        if (ef_mb_slot_encode(&m, w) != EF_OK || ef_mb_slot_decode(w, &r) != EF_OK ||
            !same_move(&m, &r)) {
            all_ok = 0;
            continue;
        }
        for (int i = m.degree + 1; i < 6; i++)
            unused_zero &= r.b[i].x == 0 && r.b[i].y == 0 && r.b[i].z == 0;
        for (int i = EF_MB_SLOT_POINTS + 6 * (m.degree + 1); i < EF_MB_SLOT_CRC; i++)
            unused_zero &= w[i] == 0;
        unused_zero &= w[EF_MB_SLOT_RESERVED] == 0 && r.tag == 0 && r.kind == 0;
        unused_zero &= (w[EF_MB_SLOT_FORMAT] & 0xFF) == m.degree;
        unused_zero &= (w[EF_MB_SLOT_FORMAT] >> 8) == ((m.flags & EF_MOVE_STOP_END) ? 1 : 0);
    }
    EF_CHECK(all_ok);
    EF_CHECK(unused_zero);

    /* Layout spot checks at the documented offsets. */
    ef_move_t m = rnd_move(&rs);
    m.degree = 5;
    m.seq = 0x00010002u;
    m.duration = 1.0f;
    m.b[5].z = -2.0f;
    m.law.c[2][3] = 0.5f;
    EF_CHECK_EQ(ef_mb_slot_encode(&m, w), EF_OK);
    EF_CHECK_EQ(w[0], 1);
    EF_CHECK_EQ(w[1], 2);
    EF_CHECK_EQ(w[4], 0x3F80);
    EF_CHECK(ef_mb_get_f32(&w[EF_MB_SLOT_POINTS + 5 * 6 + 4]) == -2.0f);
    EF_CHECK(ef_mb_get_f32(&w[EF_MB_SLOT_LAW_C + 2 * (2 * EF_TIMELAW_COEFFS + 3)]) == 0.5f);
    EF_CHECK_EQ(w[EF_MB_SLOT_CRC], ef_mb_crc_words(w, EF_MB_SLOT_CRC));

    /* Every single-bit flip anywhere in the slot is caught by the CRC. */
    int flips_caught = 1;
    for (int rep = 0; rep < 3; rep++) {
        ef_move_t mm = rnd_move(&rs), r;
        EF_CHECK_EQ(ef_mb_slot_encode(&mm, w), EF_OK);
        for (int i = 0; i < EF_MB_SLOT_WORDS; i++)
            for (int b = 0; b < 16; b++) {
                w[i] ^= (uint16_t)(1u << b);
                flips_caught &= ef_mb_slot_decode(w, &r) == EF_ERR_CRC;
                w[i] ^= (uint16_t)(1u << b);
            }
        EF_CHECK_EQ(ef_mb_slot_decode(w, &r), EF_OK);
    }
    EF_CHECK(flips_caught);

    /* Decode refusals with a valid CRC: degree, flags, reserved, NaN, duration. */
    ef_move_t r;
    m = rnd_move(&rs);
    EF_CHECK_EQ(ef_mb_slot_encode(&m, w), EF_OK);
    uint16_t bad[EF_MB_SLOT_WORDS];
#define RECRC(x) ((x)[EF_MB_SLOT_CRC] = ef_mb_crc_words((x), EF_MB_SLOT_CRC))
    memcpy(bad, w, sizeof bad);
    bad[EF_MB_SLOT_FORMAT] = (uint16_t)((bad[EF_MB_SLOT_FORMAT] & 0xFF00u) | 2u);
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_ARG);
    memcpy(bad, w, sizeof bad);
    bad[EF_MB_SLOT_FORMAT] |= 0x0200u;
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_ARG);
    memcpy(bad, w, sizeof bad);
    bad[EF_MB_SLOT_RESERVED] = 1;
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_ARG);
    memcpy(bad, w, sizeof bad);
    ef_mb_put_f32(&bad[EF_MB_SLOT_LAW_C + 6], NAN);
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_NONFINITE);
    memcpy(bad, w, sizeof bad);
    ef_mb_put_f32(&bad[EF_MB_SLOT_POINTS], INFINITY);
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_NONFINITE);
    memcpy(bad, w, sizeof bad);
    ef_mb_put_f32(&bad[EF_MB_SLOT_DURATION], 0.0f);
    RECRC(bad);
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_ARG);
    /* A NaN in an unused control point is ignored. */
    if (m.degree < 5) {
        memcpy(bad, w, sizeof bad);
        ef_mb_put_f32(&bad[EF_MB_SLOT_POINTS + 6 * 5], NAN);
        RECRC(bad);
        EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_OK);
        EF_CHECK(r.b[5].x == 0.0f);
    }
    /* CRC is checked first: a bad degree with a bad CRC reports the CRC. */
    memcpy(bad, w, sizeof bad);
    bad[EF_MB_SLOT_FORMAT] = 7;
    EF_CHECK_EQ(ef_mb_slot_decode(bad, &r), EF_ERR_CRC);
    EF_CHECK_EQ(ef_mb_slot_decode(NULL, &r), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_slot_decode(w, NULL), EF_ERR_ARG);
#undef RECRC

    /* Encode refusals. */
    ef_move_t e = m;
    e.degree = 2;
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_ERR_ARG);
    e = m;
    e.duration = 0.0f;
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_ERR_ARG);
    e = m;
    e.duration = -1.0f;
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_ERR_ARG);
    e = m;
    e.b[e.degree].y = NAN;
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_ERR_NONFINITE);
    e = m;
    e.law.dt[2] = INFINITY;
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_ERR_NONFINITE);
    e = m;
    e.degree = 1;
    e.b[4].x = NAN; /* unused: not looked at */
    EF_CHECK_EQ(ef_mb_slot_encode(&e, w), EF_OK);
    EF_CHECK_EQ(ef_mb_slot_encode(NULL, w), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_slot_encode(&m, NULL), EF_ERR_ARG);
}

/* ------------------------------------------------------------------ drive: execution */

static void test_init_args(void)
{
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    EF_CHECK_NEAR(c.wn, 2 * M_PI * 40, 1e-3);
    EF_CHECK(c.zeta == 1.0f && c.v_lim == 500.0f && c.a_lim == 20000.0f);
    EF_CHECK(c.ferr_lim == 1.0f && c.a_stop == 2000.0f);
    ef_drive_t *d = &g_d;
    ef_vec3_t o = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_drive_init(NULL, &c, o, 1000), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_init(d, NULL, o, 1000), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_init(d, &c, o, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_init(d, &c, o, 1980), EF_OK);      /* wn * T = 0.498 */
    EF_CHECK_EQ(ef_drive_init(d, &c, o, 2000), EF_ERR_ARG); /* wn * T = 0.503 */
    ef_servo_cfg_t b = c;
    b.zeta = 0.0f;
    EF_CHECK_EQ(ef_drive_init(d, &b, o, 1000), EF_ERR_ARG);
    b = c;
    b.a_stop = NAN;
    EF_CHECK_EQ(ef_drive_init(d, &b, o, 1000), EF_ERR_ARG);
    b = c;
    b.v_lim = INFINITY;
    EF_CHECK_EQ(ef_drive_init(d, &b, o, 1000), EF_ERR_ARG);
    b = c;
    b.ferr_lim = -1.0f;
    EF_CHECK_EQ(ef_drive_init(d, &b, o, 1000), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_init(d, &c, ef_v3(0, NAN, 0), 1000), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_drive_init(d, &c, ef_v3(1, 2, 3), 1000), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_DISABLED);
    EF_CHECK_EQ(d->next_seq, 0);
    EF_CHECK_EQ(ef_drive_free(d), EF_DRIVE_SLOTS);
    EF_CHECK_EQ(ef_drive_free(NULL), 0);
    EF_CHECK(d->cmd.x == 1 && d->act.z == 3);
    EF_CHECK_EQ(ef_drive_start(d), EF_ERR_STATE); /* disabled */
    EF_CHECK_EQ(ef_drive_fault(d, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_fault(d, EF_DRV_FAULT_LAST + 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_fault_reset(d), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_process(NULL, 10, NULL), EF_ERR_ARG);
}

/* The chain end to end, with dt values that are not multiples of the period, taken as
 * differences of a wrapping 32-bit microsecond counter. */
static void test_chain(void)
{
    ef_move_t mv[5];
    int n = mk_chain(mv);
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_OK);
    EF_CHECK_EQ(d->next_seq, 5);
    EF_CHECK_EQ(ef_drive_free(d), EF_DRIVE_SLOTS - 5);
    /* ENABLED does not execute. */
    EF_CHECK_EQ(ef_drive_process(d, 5000, NULL), EF_OK);
    EF_CHECK(d->cmd.x == 0.0f && d->time_ms == 0);
    d->acc_us = 0;
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK); /* already running: no effect */
    EF_CHECK_EQ(d->state, EF_DRV_RUNNING);

    double total = 0;
    for (int i = 0; i < n; i++)
        total += mv[i].duration;
    static const uint32_t dts[] = {700, 1300, 2500, 450, 1000, 3333, 999, 1};
    uint32_t clock = 0xFFFFF000u, prev = clock; /* wraps after ~4 ms */
    uint64_t elapsed = 0;
    double worst = 0, ferr_seen = 0;
    int bad_rc = 0, exec_ok = 1, done_mono = 1;
    uint32_t last_done = 0;
    for (int it = 0; it < 100000 && elapsed * 1e-6 < total + 0.5; it++) {
        clock += dts[it % 8];
        uint32_t dt = clock - prev; /* wraps harmlessly */
        prev = clock;
        uint32_t next_us = 0;
        bad_rc |= ef_drive_process(d, dt, &next_us) != EF_OK;
        elapsed += dt;
        uint64_t steps = elapsed / PERIOD_US;
        EF_CHECK_EQ(next_us, PERIOD_US - elapsed % PERIOD_US);
        double T = (double)steps * PERIOD_US * 1e-6, want[3];
        tm_chain_pos(mv, n, T, want);
        double e = dist3(d->cmd, want);
        if (e > worst)
            worst = e;
        if (d->ferr > ferr_seen)
            ferr_seen = d->ferr;
        if (d->moving) {
            /* the executing segment is the one the independent schedule says */
            double t0 = 0;
            int k = 0;
            while (k < n - 1 && T >= t0 + mv[k].duration) {
                t0 += mv[k].duration;
                k++;
            }
            double into = T - t0;
            if (into > 1e-5 && mv[k].duration - into > 1e-5)
                exec_ok &= d->exec_seq == (uint32_t)k;
        }
        if (d->done_any) {
            done_mono &= d->done_seq >= last_done;
            last_done = d->done_seq;
        }
    }
    EF_CHECK(!bad_rc);
    EF_CHECK_NEAR(worst, 0, 2e-4);
    EF_CHECK(exec_ok);
    EF_CHECK(done_mono);
    EF_CHECK_EQ(d->state, EF_DRV_RUNNING); /* waits for more at rest */
    EF_CHECK_EQ(d->moving, 0);
    EF_CHECK_EQ(d->done_any, 5);
    EF_CHECK_EQ(d->done_seq, 4);
    EF_CHECK(d->cmd.x == 50.0f && d->cmd.y == 5.0f && d->cmd.z == 2.0f);
    EF_CHECK(d->ferr_max >= ferr_seen && d->ferr_max > 1e-4 && d->ferr_max < 0.1);
    /* Executed time counts RUNNING periods only. */
    uint32_t ms = d->time_ms;
    EF_CHECK_NEAR(ms + d->time_us * 1e-3, (double)(elapsed / PERIOD_US), 1e-9);
    /* The servo settles onto the end. */
    for (int i = 0; i < 300; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_NEAR(d->act.x, 50.0, 1e-4);
    EF_CHECK_NEAR(d->act.y, 5.0, 1e-4);
    EF_CHECK_NEAR(d->ferr, 0, 1e-4);
    EF_CHECK_NEAR(vlen(d->act_vel), 0, 1e-3);
    /* Duplicates are acknowledged, not executed again; a gap is refused. */
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_ERR_DUP);
    ef_move_t gap = mk_line(6, ef_v3(50, 5, 2), ef_v3(60, 5, 2), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &gap), EF_ERR_SEQ);
    EF_CHECK_EQ(d->next_seq, 5);
    for (int i = 0; i < 100; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(d->done_any, 5);
    EF_CHECK(d->cmd.x == 50.0f);
    /* The next segment, while RUNNING idle, runs at once. */
    ef_move_t nx = mk_line(5, ef_v3(50, 5, 2), ef_v3(55, 5, 2), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &nx), EF_OK);
    for (int i = 0; i < 400; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(d->done_seq, 5);
    EF_CHECK_EQ(d->done_any, 6);
    EF_CHECK(d->cmd.x == 55.0f);
    /* Clear at rest: sequence from 0 again, counters reset. */
    EF_CHECK_EQ(ef_drive_clear(d), EF_OK);
    EF_CHECK_EQ(d->next_seq, 0);
    EF_CHECK_EQ(d->done_any, 0);
    EF_CHECK_EQ(d->time_ms, 0);
    EF_CHECK(d->ferr_max == 0.0f);
}

/* Refusals at push: state, sequence, continuity, data, full ring. */
static void test_push_checks(void)
{
    ef_drive_t *d = &g_d;
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    EF_CHECK_EQ(ef_drive_init(d, &c, ef_v3(0, 0, 0), PERIOD_US), EF_OK);
    ef_move_t m0 = mk_line(0, ef_v3(0, 0, 0), ef_v3(1, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &m0), EF_ERR_STATE); /* disabled */
    EF_CHECK_EQ(ef_drive_enable(d, 1), EF_OK);
    EF_CHECK_EQ(ef_drive_push(NULL, &m0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_drive_push(d, NULL), EF_ERR_ARG);
    ef_move_t b = m0;
    b.b[0].x = 0.01f; /* not where the drive is */
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_ERR_ARG);
    b = m0;
    b.degree = 2;
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_ERR_ARG);
    b = m0;
    b.duration = 0;
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_ERR_ARG);
    b = m0;
    b.law.c[0][1] = NAN;
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_ERR_ARG);
    b = m0;
    b.b[1].z = INFINITY;
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_ERR_ARG);
    EF_CHECK_EQ(d->next_seq, 0);
    b = m0;
    b.b[0].y = 5e-4f; /* within the join tolerance */
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_OK);
    EF_CHECK_EQ(ef_drive_push(d, &m0), EF_ERR_DUP);
    /* 15 more fill the ring; continuity is checked against the last queued end. */
    ef_vec3_t at = ef_v3(1, 0, 0);
    for (uint32_t s = 1; s < EF_DRIVE_SLOTS; s++) {
        ef_move_t m = mk_line(s, at, ef_v3(at.x + 1, 0, 0), LAW_DECEL);
        ef_move_t off = m;
        off.b[0] = ef_v3(at.x - 1, 0, 0);
        EF_CHECK_EQ(ef_drive_push(d, &off), EF_ERR_ARG);
        EF_CHECK_EQ(ef_drive_push(d, &m), EF_OK);
        at.x += 1;
    }
    EF_CHECK_EQ(ef_drive_free(d), 0);
    ef_move_t more = mk_line(EF_DRIVE_SLOTS, at, ef_v3(at.x + 1, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &more), EF_ERR_FULL);
    ef_move_t far = mk_line(EF_DRIVE_SLOTS + 1, at, ef_v3(at.x + 1, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &far), EF_ERR_SEQ);
    /* Running drains the ring into the interpolator: room again, and the continuity check
     * now looks at the interpolator's end. */
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    EF_CHECK_EQ(ef_drive_process(d, PERIOD_US, NULL), EF_OK);
    EF_CHECK(ef_drive_free(d) >= EF_INTERP_QUEUE - 1);
    EF_CHECK_EQ(ef_drive_push(d, &more), EF_OK);
    EF_CHECK_EQ(ef_drive_clear(d), EF_ERR_STATE); /* moving */
    /* Direct mode refuses segments and start, and cannot be chosen while running. */
    EF_CHECK_EQ(ef_drive_set_direct(d, 1), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_set_target(d, ef_v3(0, 0, 0)), EF_ERR_STATE);
    for (int i = 0; i < 20000 && (d->moving || d->done_any < EF_DRIVE_SLOTS + 1); i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(d->done_any, EF_DRIVE_SLOTS + 1);
    EF_CHECK_EQ(d->done_seq, EF_DRIVE_SLOTS);
    EF_CHECK_NEAR(d->cmd.x, EF_DRIVE_SLOTS + 1, 1e-5);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
}

/* ------------------------------------------------------------------ drive: stops, faults */

/* Run until the state leaves STOPPING, checking the stop ramp: constant direction, speed
 * strictly decreasing to 0, no position jump. Returns the periods stepped. */
static int watch_stop(ef_drive_t *d, double v_start, int *ok)
{
    double v_prev = v_start;
    ef_vec3_t p_prev = d->cmd;
    int k = 0;
    for (; k < 10000 && d->state == EF_DRV_STOPPING; k++) {
        ef_drive_process(d, PERIOD_US, NULL);
        double v = vlen(d->cmd_vel);
        double step = vlen(ef_v3_sub(d->cmd, p_prev));
        int g = (v < v_prev || v == 0) && step <= v_prev * PERIOD_US * 1e-6 + 1e-5 &&
                fabs(v_prev - v) <= d->cfg.a_stop * PERIOD_US * 1e-6 * 1.001 + 1e-6;
        if (!g)
            fprintf(stderr, "stop step %d: v %g -> %g, moved %g\n", k, v_prev, v, step);
        *ok &= g;
        v_prev = v;
        p_prev = d->cmd;
    }
    *ok &= v_prev == 0;
    return k;
}

static void test_underrun(void)
{
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    /* One cruise segment that ends moving, and nothing after it. */
    ef_move_t a = mk_line(0, ef_v3(0, 0, 0), ef_v3(3, 4, 0), LAW_CRUISE); /* 5 units at 50: 0.1 s */
    EF_CHECK_EQ(ef_drive_push(d, &a), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    int drive_rc = 0, steps = 0;
    ef_vec3_t p_prev = d->cmd;
    double vmax_jump = 0, v_before = 0;
    for (; steps < 1000 && d->fault == EF_DRV_FAULT_NONE; steps++) {
        v_before = vlen(d->cmd_vel);
        p_prev = d->cmd;
        int rc = ef_drive_process(d, PERIOD_US, NULL);
        if (rc == EF_ERR_DRIVE)
            drive_rc++;
        double j = vlen(ef_v3_sub(d->cmd, p_prev));
        if (j > vmax_jump)
            vmax_jump = j;
    }
    EF_CHECK_EQ(drive_rc, 1);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_UNDERRUN);
    EF_CHECK_EQ(d->state, EF_DRV_STOPPING);
    EF_CHECK_NEAR(v_before, 50.0, 0.01);
    EF_CHECK(vmax_jump <= 50.0 * 1e-3 + 1e-5);
    EF_CHECK_EQ(d->done_any, 1); /* the segment itself was finished */
    EF_CHECK_EQ(ef_drive_push(d, &a), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_enable(d, 1), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_fault_reset(d), EF_ERR_STATE); /* still stopping */
    EF_CHECK_EQ(ef_drive_clear(d), EF_ERR_STATE);
    int ok = 1;
    ef_vec3_t stop_from = d->cmd;
    /* The fault's period already took the first ramp step: 48 units/s left. */
    double v_left = vlen(d->cmd_vel), want_dist = 0;
    EF_CHECK_NEAR(v_left, 48.0, 0.01);
    for (double s = v_left - 2.0; s > 1e-9; s -= 2.0)
        want_dist += s * 1e-3;
    int k = watch_stop(d, v_left, &ok);
    EF_CHECK(ok);
    EF_CHECK(k >= 20 && k <= 30); /* 50 / 2000 = 25 ms */
    EF_CHECK_EQ(d->state, EF_DRV_FAULT);
    /* The stop continued along the segment's direction, about v^2 / (2 a) further. */
    ef_vec3_t dir = ef_v3_sub(d->cmd, stop_from);
    EF_CHECK_NEAR(vlen(dir), want_dist, 1e-3); /* about v^2 / (2 a_stop) */
    EF_CHECK_NEAR(dir.x * 4 - dir.y * 3, 0, 1e-4);
    /* Later process calls do not report the fault again. */
    EF_CHECK_EQ(ef_drive_process(d, 10 * PERIOD_US, NULL), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_ERR_STATE);
    ef_vec3_t frozen = d->cmd;
    EF_CHECK(d->cmd.x == frozen.x && d->cmd.y == frozen.y);
    /* A second fault does not replace the first. */
    EF_CHECK_EQ(ef_drive_fault(d, EF_DRV_FAULT_INJECTED), EF_OK);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_UNDERRUN);
    /* Fault reset: DISABLED, sequence from 0; enable takes the actual position. */
    EF_CHECK_EQ(ef_drive_fault_reset(d), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_DISABLED);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
    EF_CHECK_EQ(d->next_seq, 0);
    EF_CHECK_EQ(d->done_any, 0);
    for (int i = 0; i < 200; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(ef_drive_enable(d, 1), EF_OK);
    EF_CHECK(d->cmd.x == d->act.x && d->cmd.y == d->act.y);
    ef_move_t b = mk_line(0, d->cmd, ef_v3(d->cmd.x + 1, d->cmd.y, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_OK);
}

static void test_following(void)
{
    ef_drive_t *d = &g_d;
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    c.ferr_lim = 1e-3f;
    drive_up(d, &c);
    ef_move_t mv[5];
    int n = mk_chain(mv);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    int rc = EF_OK, i = 0;
    for (; i < 5000 && rc == EF_OK; i++)
        rc = ef_drive_process(d, 3 * PERIOD_US + 17, NULL);
    EF_CHECK_EQ(rc, EF_ERR_DRIVE);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_FOLLOWING);
    EF_CHECK(d->ferr_max > 1e-3f);
    EF_CHECK(d->state == EF_DRV_STOPPING || d->state == EF_DRV_FAULT);
    for (int k = 0; k < 200; k++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(d->state, EF_DRV_FAULT);
    EF_CHECK(d->done_any < 5);
    EF_CHECK_NEAR(vlen(d->cmd_vel), 0, 0);
}

static void test_quick_stop(void)
{
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    ef_move_t a = mk_line(0, ef_v3(0, 0, 0), ef_v3(10, 0, 0), LAW_ACCEL);
    ef_move_t b = mk_line(1, ef_v3(10, 0, 0), ef_v3(20, 0, 0), LAW_CRUISE);
    ef_move_t c = mk_line(2, ef_v3(20, 0, 0), ef_v3(30, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &a), EF_OK);
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_OK);
    EF_CHECK_EQ(ef_drive_push(d, &c), EF_OK);
    EF_CHECK_EQ(ef_drive_quick_stop(d), EF_OK); /* not running: no effect */
    EF_CHECK_EQ(ef_drive_free(d), EF_DRIVE_SLOTS - 3);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    for (int i = 0; i < 500; i++) /* 0.4 s accelerating, then 0.1 s into b */
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(d->exec_seq, 1);
    EF_CHECK_EQ(d->done_seq, 0);
    double v = vlen(d->cmd_vel);
    EF_CHECK_NEAR(v, 50.0, 0.01);
    uint32_t t_ms = d->time_ms;
    EF_CHECK_EQ(ef_drive_quick_stop(d), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_STOPPING);
    EF_CHECK_EQ(ef_drive_free(d), EF_DRIVE_SLOTS);
    int ok = 1;
    watch_stop(d, v, &ok);
    EF_CHECK(ok);
    EF_CHECK_EQ(d->state, EF_DRV_ENABLED);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
    EF_CHECK(d->time_ms > t_ms); /* STOPPING counts as executed time */
    EF_CHECK_NEAR(d->cmd.x, 15.0 + 0.625, 0.06);
    EF_CHECK_EQ(d->next_seq, 3);
    EF_CHECK_EQ(d->done_any, 1); /* b and c were not executed */
    /* A late retry is a duplicate; the next segment must start where the drive stopped. */
    EF_CHECK_EQ(ef_drive_push(d, &c), EF_ERR_DUP);
    ef_move_t stale = mk_line(3, ef_v3(30, 0, 0), ef_v3(40, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &stale), EF_ERR_ARG);
    ef_move_t back = mk_line(3, d->cmd, ef_v3(0, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &back), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    for (int i = 0; i < 2000; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK(d->cmd.x == 0.0f);
    EF_CHECK_EQ(d->done_seq, 3);
    /* Disable while moving: a controlled stop, then DISABLED. */
    ef_move_t e = mk_line(4, ef_v3(0, 0, 0), ef_v3(0, 10, 0), LAW_ACCEL);
    EF_CHECK_EQ(ef_drive_push(d, &e), EF_OK);
    for (int i = 0; i < 300; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    v = vlen(d->cmd_vel);
    EF_CHECK(v > 10);
    EF_CHECK_EQ(ef_drive_enable(d, 0), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_STOPPING);
    ok = 1;
    watch_stop(d, v, &ok);
    EF_CHECK(ok);
    EF_CHECK_EQ(d->state, EF_DRV_DISABLED);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
    /* Injected fault at rest: straight to FAULT. */
    EF_CHECK_EQ(ef_drive_enable(d, 1), EF_OK);
    EF_CHECK_EQ(ef_drive_fault(d, EF_DRV_FAULT_INJECTED), EF_OK);
    EF_CHECK_EQ(d->state, EF_DRV_FAULT);
    EF_CHECK_EQ(ef_drive_process(d, PERIOD_US, NULL), EF_OK); /* raised outside the call */
}

/* ------------------------------------------------------------------ feed hold */

/* The chain sampled every 0.1 ms, the reference the held drive's command must lie on. */
#define HOLD_REF_DT 1e-4
#define HOLD_REF_N  40000
static double g_ref[HOLD_REF_N][3];
static int g_ref_n;

static void hold_ref(const ef_move_t *mv, int n)
{
    double total = 0;
    for (int i = 0; i < n; i++)
        total += mv[i].duration;
    g_ref_n = (int)(total / HOLD_REF_DT) + 2;
    EF_CHECK(g_ref_n <= HOLD_REF_N);
    for (int i = 0; i < g_ref_n && i < HOLD_REF_N; i++)
        tm_chain_pos(mv, n, i * HOLD_REF_DT, g_ref[i]);
}

/* Distance from p to the reference polyline's piece i .. i + 1. */
static double hold_seg_dist(ef_vec3_t p, int i)
{
    const double *a = g_ref[i], *b = g_ref[i + 1];
    double ab[3], ap[3], l2 = 0, dot = 0;
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k];
        ap[k] = (k == 0 ? p.x : k == 1 ? p.y : p.z) - a[k];
        l2 += ab[k] * ab[k];
        dot += ab[k] * ap[k];
    }
    double u = l2 > 0 ? dot / l2 : 0;
    u = u < 0 ? 0 : u > 1 ? 1 : u;
    double q[3] = {a[0] + u * ab[0], a[1] + u * ab[1], a[2] + u * ab[2]};
    return dist3(p, q);
}

/* Distance from the reference path near piece *j (it only moves forward: progress never
 * goes back), and the nearest piece. */
static double hold_on_path(ef_vec3_t p, int *j)
{
    double best = 1e30;
    int bi = *j;
    for (int i = *j; i + 1 < g_ref_n && i < *j + 200; i++) {
        double e = hold_seg_dist(p, i);
        if (e < best) {
            best = e;
            bi = i;
        }
    }
    *j = bi;
    return best;
}

/* A feed hold at cruise: the command decelerates along the path within a_stop / 2 of added
 * deceleration, in v T / 2 of path (T = 3 v / a_stop), stands there while held (RUNNING,
 * no underrun, no fault), resumes on release and completes the chain exactly: every
 * command lies on the path and progress never goes back. */
static void test_hold(void)
{
    ef_move_t mv[5];
    int n = mk_chain(mv);
    hold_ref(mv, n);
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    double dt = PERIOD_US * 1e-6, off = 0, back = 0, v_prev = 0, acc = 0;
    int j = 0, k = 0, phase = 0, bad_rc = 0, checked = 0;
    ef_vec3_t prev = d->cmd, at_hold = d->cmd, at_rest = d->cmd;
    uint32_t held_periods = 0, ramp_periods = 0;
    for (k = 0; k < 20000; k++) {
        if (phase == 0 && d->exec_seq == 1 && d->moving) { /* the cruise line at V0 */
            EF_CHECK_EQ(ef_drive_hold(d, 1), EF_OK);
            EF_CHECK_EQ(ef_drive_hold(d, 1), EF_OK); /* the same request: no new ramp */
            at_hold = d->cmd;
            v_prev = V0;
            phase = 1;
        }
        bad_rc |= ef_drive_process(d, PERIOD_US, NULL) != EF_OK;
        int j0 = j;
        double e = hold_on_path(d->cmd, &j);
        off = e > off ? e : off;
        back += j < j0;
        double v = vlen(ef_v3_sub(d->cmd, prev)) / dt;
        prev = d->cmd;
        if (phase == 1) {
            ramp_periods++;
            double a = (v_prev - v) / dt; /* added deceleration along the path at V0 */
            acc = a > acc ? a : acc;
            v_prev = v;
            if (d->held) {
                EF_CHECK_NEAR(v, 0, 1e-6);
                at_rest = d->cmd;
                phase = 2;
            }
        } else if (phase == 2) {
            /* Held: nothing moves, still RUNNING, the ring is kept. */
            checked += d->cmd.x == at_rest.x && d->cmd.y == at_rest.y && d->cmd.z == at_rest.z &&
                       d->state == EF_DRV_RUNNING && d->held && d->moving;
            if (++held_periods == 500) {
                EF_CHECK_EQ(ef_drive_hold(d, 0), EF_OK);
                EF_CHECK(!d->held);
                phase = 3;
            }
        } else if (phase == 3 && !d->moving && d->done_any == 5) {
            break;
        }
    }
    EF_CHECK(!bad_rc);
    EF_CHECK_EQ(phase, 3);
    EF_CHECK_EQ(checked, 500);
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
    EF_CHECK_EQ(d->state, EF_DRV_RUNNING);
    EF_CHECK_EQ(d->done_any, 5);
    EF_CHECK_EQ(d->done_seq, 4);
    EF_CHECK(d->cmd.x == 50.0f && d->cmd.y == 5.0f && d->cmd.z == 2.0f);
    EF_CHECK_NEAR(off, 0, 2e-5);    /* on the path throughout */
    EF_CHECK_EQ(back, 0);           /* never backwards */
    EF_CHECK(acc <= 1000.0 * 1.02); /* a_stop / 2 (default a_stop 2000) */
    EF_CHECK(acc >= 1000.0 * 0.9);  /* and the ramp is the short one allowed, not a crawl */
    /* T = 3 V0 / a_stop = 75 ms; the smoothstep's distance is V0 T / 2 (arc, ~ chord here). */
    EF_CHECK(ramp_periods >= 74 && ramp_periods <= 77);
    double dist = vlen(ef_v3_sub(at_rest, at_hold));
    EF_CHECK(dist > 0.9 * V0 * 0.075 / 2 && dist <= V0 * 0.075 / 2 + 0.05);
    EF_CHECK(d->ferr_max < 0.1);
    printf("hold: stood %.3f mm after the request (ramp %u ms, peak added deceleration %.0f "
           "units/s^2), off the path at most %.2g\n",
           dist, (unsigned)ramp_periods, acc, off);

    /* A hold at rest applies at once: it starts RUNNING and stands; a release starts it. */
    drive_up(d, NULL);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_OK);
    EF_CHECK_EQ(ef_drive_hold(d, 1), EF_OK);
    EF_CHECK(d->held && d->rate == 0.0f);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    for (int i = 0; i < 200; i++)
        EF_CHECK_EQ(ef_drive_process(d, PERIOD_US, NULL), EF_OK);
    EF_CHECK(d->cmd.x == 0.0f && d->held && d->state == EF_DRV_RUNNING);
    EF_CHECK_EQ(ef_drive_hold(d, 0), EF_OK);
    j = 0;
    off = 0;
    for (int i = 0; i < 5000 && d->done_any < 5; i++) {
        EF_CHECK_EQ(ef_drive_process(d, PERIOD_US, NULL), EF_OK);
        double e = hold_on_path(d->cmd, &j);
        off = e > off ? e : off;
    }
    EF_CHECK_EQ(d->done_any, 5);
    EF_CHECK_NEAR(off, 0, 2e-5);

    /* A quick stop during a hold's ramp stops as ever; the hold stays requested. */
    drive_up(d, NULL);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(ef_drive_push(d, &mv[i]), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_OK);
    for (int i = 0; i < 300; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_EQ(ef_drive_hold(d, 1), EF_OK);
    for (int i = 0; i < 20; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK(d->rate > 0.0f && d->rate < 1.0f);
    EF_CHECK_EQ(ef_drive_quick_stop(d), EF_OK);
    int ok = 1;
    watch_stop(d, vlen(d->cmd_vel), &ok);
    EF_CHECK(ok);
    EF_CHECK_EQ(d->state, EF_DRV_ENABLED);
    EF_CHECK(d->hold && d->held && d->rate == 0.0f);

    /* Direct mode refuses a hold; entering it clears one. Bad arguments. */
    EF_CHECK_EQ(ef_drive_set_direct(d, 1), EF_OK);
    EF_CHECK(!d->hold && d->rate == 1.0f);
    EF_CHECK_EQ(ef_drive_hold(d, 1), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_hold(d, 0), EF_OK);
    EF_CHECK_EQ(ef_drive_hold(NULL, 1), EF_ERR_ARG);

    /* The interpolator's rate: NaN stands still, above 1 is 1. */
    ef_interp_t ip;
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), PERIOD_US, EF_STEP_UNIFORM), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &mv[0]), EF_OK);
    ef_setpoint_t sp;
    for (int i = 0; i < 50; i++)
        EF_CHECK_EQ(ef_interp_process_rate(&ip, PERIOD_US, (float)NAN, NULL, &sp), EF_OK);
    EF_CHECK(sp.p.x == 0.0f && sp.moving);
    ef_interp_t iq = ip;
    ef_setpoint_t sq;
    for (int i = 0; i < 50; i++) {
        EF_CHECK_EQ(ef_interp_process_rate(&ip, PERIOD_US, 7.0f, NULL, &sp), EF_OK);
        EF_CHECK_EQ(ef_interp_process(&iq, PERIOD_US, NULL, &sq), EF_OK);
    }
    EF_CHECK(sp.p.x == sq.p.x && sp.p.x > 0.0f);
    EF_CHECK_EQ(ef_interp_process_rate(NULL, PERIOD_US, 1.0f, NULL, &sp), EF_ERR_ARG);
}

static void test_direct(void)
{
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    EF_CHECK_EQ(ef_drive_set_target(d, ef_v3(1, 1, 1)), EF_ERR_STATE); /* segment mode */
    EF_CHECK_EQ(ef_drive_set_direct(d, 1), EF_OK);
    EF_CHECK_EQ(ef_drive_start(d), EF_ERR_STATE);
    ef_move_t a = mk_line(0, ef_v3(0, 0, 0), ef_v3(1, 0, 0), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &a), EF_ERR_STATE);
    EF_CHECK_EQ(ef_drive_set_target(d, ef_v3(NAN, 0, 0)), EF_ERR_NONFINITE);
    ef_vec3_t goal = ef_v3(40, -7.5f, 0.25f);
    EF_CHECK_EQ(ef_drive_set_target(d, goal), EF_OK);
    double vmax = 0, amax = 0;
    ef_vec3_t vprev = d->cmd_vel;
    int k = 0;
    for (; k < 5000; k++) {
        ef_drive_process(d, 250, NULL); /* a quarter period per call */
        double ax = fabs(d->cmd_vel.x - vprev.x) / 1e-3;
        double ay = fabs(d->cmd_vel.y - vprev.y) / 1e-3;
        amax = fmax(amax, fmax(ax, ay));
        vmax = fmax(vmax, fmax(fabs(d->cmd_vel.x), fabs(d->cmd_vel.y)));
        vprev = d->cmd_vel;
        if (d->cmd.x == goal.x && d->cmd.y == goal.y && d->cmd.z == goal.z && vlen(d->cmd_vel) == 0)
            break;
    }
    EF_CHECK(k < 5000);
    EF_CHECK(vmax <= 500.0 * 1.0001);
    EF_CHECK(amax <= 0.5 * 20000.0 * 1.001); /* the profile uses half of a_lim */
    EF_CHECK_NEAR(vmax, 500, 1);             /* 40 units is long enough to reach v_lim */
    EF_CHECK_EQ(d->time_ms, 0);              /* direct motion is not job time */
    EF_CHECK_EQ(d->fault, EF_DRV_FAULT_NONE);
    for (int i = 0; i < 300; i++)
        ef_drive_process(d, PERIOD_US, NULL);
    EF_CHECK_NEAR(d->act.x, 40, 1e-4);
    EF_CHECK(d->ferr_max < 0.6f);
    EF_CHECK_NEAR(d->act.y, -7.5, 1e-4);
    /* Back to segment mode: segments start at the reached position. */
    EF_CHECK_EQ(ef_drive_set_direct(d, 0), EF_OK);
    ef_move_t b = mk_line(0, goal, ef_v3(41, -7.5f, 0.25f), LAW_DECEL);
    EF_CHECK_EQ(ef_drive_push(d, &b), EF_OK);
}

/* Late calls: at most EF_DRIVE_MAX_STEPS periods, the rest counted as dropped. */
static void test_late(void)
{
    ef_drive_t *d = &g_d;
    drive_up(d, NULL);
    uint32_t next = 0;
    EF_CHECK_EQ(ef_drive_process(d, 400, &next), EF_OK);
    EF_CHECK_EQ(next, 600);
    EF_CHECK_EQ(ef_drive_process(d, 100000 + 700, &next), EF_OK);
    /* 100.7 ms + 0.4 ms = 101 periods + 100 us; 64 stepped, 37 dropped */
    EF_CHECK_EQ(d->late_us, (101 - EF_DRIVE_MAX_STEPS) * 1000);
    EF_CHECK_EQ(next, 900);
    EF_CHECK_EQ(ef_drive_process(d, 0xFFFFFFFFu, &next), EF_OK);
    EF_CHECK(d->late_us > 4000000000u);
    EF_CHECK(next >= 1 && next <= PERIOD_US);
}

/* ------------------------------------------------------------------ Modbus device */

static ef_mbdev_t g_dev;

static uint32_t rd32(ef_mbdev_t *dev, uint16_t a)
{
    uint16_t w[2];
    uint8_t exc = 0xFF;
    EF_CHECK_EQ(ef_mbdev_read(dev, a, 2, w, &exc), EF_OK);
    return ef_mb_get_u32(w);
}

static uint16_t rd16(ef_mbdev_t *dev, uint16_t a)
{
    uint16_t w = 0;
    uint8_t exc = 0xFF;
    EF_CHECK_EQ(ef_mbdev_read(dev, a, 1, &w, &exc), EF_OK);
    return w;
}

static int wr1(ef_mbdev_t *dev, uint16_t a, uint16_t v, uint8_t *exc)
{
    return ef_mbdev_write(dev, a, 1, &v, exc);
}

static int wr_slot(ef_mbdev_t *dev, uint32_t k, const ef_move_t *m, uint8_t *exc)
{
    uint16_t w[EF_MB_SLOT_WORDS];
    EF_CHECK_EQ(ef_mb_slot_encode(m, w), EF_OK);
    return ef_mbdev_write(dev, (uint16_t)(EF_MB_REG_SLOT0 + k * EF_MB_SLOT_WORDS), EF_MB_SLOT_WORDS,
                          w, exc);
}

static void test_mbdev(void)
{
    ef_mbdev_t *dev = &g_dev;
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    ef_vec3_t o = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_mbdev_init(dev, &c, o, PERIOD_US, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_init(dev, &c, o, 0, 7), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_init(dev, &c, ef_v3(INFINITY, 0, 0), PERIOD_US, 7), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_mbdev_init(dev, &c, o, PERIOD_US, 0x1234), EF_OK);

    /* Identification block. */
    uint16_t id[8];
    uint8_t exc = 0xFF;
    EF_CHECK_EQ(ef_mbdev_read(dev, 0, 8, id, &exc), EF_OK);
    EF_CHECK_EQ(exc, EF_MB_EX_NONE);
    EF_CHECK_EQ(id[0], 0x4546);
    EF_CHECK_EQ(id[1], EF_MB_MAP_VERSION);
    EF_CHECK_EQ(id[2], 3);
    EF_CHECK_EQ(id[3], EF_DRIVE_SLOTS);
    EF_CHECK_EQ(id[4], EF_MB_SLOT_WORDS);
    EF_CHECK_EQ(id[5], 0x1234);
    EF_CHECK_EQ(ef_mb_get_u32(&id[6]), PERIOD_US);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_SEQ), EF_MB_DONE_NONE);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_MODE), EF_MB_MODE_SEGMENT);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_STATE), EF_DRV_DISABLED);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_FREE), EF_DRIVE_SLOTS);
    EF_CHECK_EQ(rd16(dev, 0x0013), 0); /* a hole */
    EF_CHECK_EQ(rd16(dev, 0x00FF), 0);
    uint16_t big[125];
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REGS - 125, 125, big, &exc), EF_OK);

    /* Out of range / bad count reads. */
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REGS - 1, 2, big, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_read(dev, 0, 0, big, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_read(dev, 0, 126, big, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_read(dev, 0xFFFF, 1, big, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);

    /* Writes that are refused by address; each counts as rejected. */
    uint16_t z[EF_MB_SLOT_WORDS] = {0};
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_STATUS, 1, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_MAGIC, 1, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_WATCHDOG, 2, z, &exc), EF_ERR_ARG); /* spills */
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_TARGET, 3, z, &exc), EF_ERR_ARG); /* partial */
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS - 1, z, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_SLOT0 + 1, EF_MB_SLOT_WORDS, z, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REGS - 1, 2, z, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(dev, 0x0010, 0, z, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_REJECTED), 8);

    /* A segment while disabled: refused by state. */
    ef_move_t mv[5];
    int n = mk_chain(mv);
    EF_CHECK_EQ(wr_slot(dev, 0, &mv[0], &exc), EF_ERR_STATE);
    EF_CHECK_EQ(exc, EF_MB_EX_DEVICE_FAILURE);
    /* Control values. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, 0x0100, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_MODE, 3, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_FAULT_RESET, &exc), EF_ERR_STATE);
    EF_CHECK_EQ(exc, EF_MB_EX_DEVICE_FAILURE);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_REJECTED), 12);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE, &exc), EF_OK);
    EF_CHECK_EQ(exc, EF_MB_EX_NONE);
    EF_CHECK_EQ(dev->drv.state, EF_DRV_ENABLED);
    EF_CHECK(rd16(dev, EF_MB_REG_STATUS) & EF_MB_ST_ENABLED);
    /* Target only in direct mode. */
    uint16_t tw[6];
    ef_mb_put_f32(&tw[0], 1.0f);
    ef_mb_put_f32(&tw[2], 2.0f);
    ef_mb_put_f32(&tw[4], 3.0f);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_TARGET, 6, tw, &exc), EF_ERR_STATE);
    EF_CHECK_EQ(exc, EF_MB_EX_DEVICE_FAILURE);

    /* Slots: bad CRC, wrong index, gap, then the chain; duplicate acknowledged. */
    uint16_t w[EF_MB_SLOT_WORDS];
    EF_CHECK_EQ(ef_mb_slot_encode(&mv[0], w), EF_OK);
    w[10] ^= 0x0040u;
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, w, &exc), EF_ERR_CRC);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    EF_CHECK_EQ(wr_slot(dev, 1, &mv[0], &exc), EF_ERR_SEQ);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    EF_CHECK_EQ(wr_slot(dev, 1, &mv[1], &exc), EF_ERR_SEQ); /* gap: 0 expected */
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    ef_move_t off = mv[0];
    off.b[0].x = 1.0f; /* not where the drive is */
    EF_CHECK_EQ(wr_slot(dev, 0, &off, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    for (int i = 0; i < n; i++) {
        EF_CHECK_EQ(wr_slot(dev, (uint32_t)i, &mv[i], &exc), EF_OK);
        EF_CHECK_EQ(exc, EF_MB_EX_NONE);
    }
    EF_CHECK_EQ(wr_slot(dev, 3, &mv[3], &exc), EF_OK); /* retried */
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_DUPLICATES), 1);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_NEXT_SEQ), 5);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_HEAD), 5);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_TAIL), 0);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_FREE), EF_DRIVE_SLOTS - 5);
    /* Slot contents read back. */
    uint16_t back[EF_MB_SLOT_WORDS];
    EF_CHECK_EQ(ef_mb_slot_encode(&mv[2], w), EF_OK);
    EF_CHECK_EQ(
        ef_mbdev_read(dev, EF_MB_REG_SLOT0 + 2 * EF_MB_SLOT_WORDS, EF_MB_SLOT_WORDS, back, &exc),
        EF_OK);
    EF_CHECK(memcmp(back, w, sizeof w) == 0);
    /* The mode cannot change while running. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc), EF_OK);
    EF_CHECK_EQ(dev->drv.state, EF_DRV_RUNNING);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_MODE, EF_MB_MODE_DIRECT, &exc), EF_ERR_STATE);
    EF_CHECK_EQ(exc, EF_MB_EX_DEVICE_FAILURE);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_CLEAR, &exc),
                EF_OK); /* running but not moving yet: clear allowed */
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_NEXT_SEQ), 0);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(wr_slot(dev, (uint32_t)i, &mv[i], &exc), EF_OK);
    /* Run with a polling master; status reflects progress. */
    int saw_moving = 0, saw_exec = 1;
    for (int i = 0; i < 3000; i++) {
        EF_CHECK_EQ(ef_mbdev_process(dev, 1500, NULL) == EF_OK, 1);
        if (i % 10 == 0) {
            uint16_t st = rd16(dev, EF_MB_REG_STATUS);
            if (st & EF_MB_ST_MOVING) {
                saw_moving = 1;
                uint32_t ex = rd32(dev, EF_MB_REG_EXEC_SEQ);
                saw_exec &= ex < 5 && rd16(dev, EF_MB_REG_TAIL) == ex % EF_DRIVE_SLOTS;
            }
        }
    }
    EF_CHECK(saw_moving && saw_exec);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_SEQ), 4);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_COUNT), 5);
    EF_CHECK(rd32(dev, EF_MB_REG_TIME_MS) >= 1400);
    uint16_t pos[12];
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REG_ACT, 12, pos, &exc), EF_OK);
    EF_CHECK_NEAR(ef_mb_get_f32(&pos[0]), 50.0, 1e-3);
    EF_CHECK(ef_mb_get_f32(&pos[6]) == 50.0f && ef_mb_get_f32(&pos[8]) == 5.0f);
    float fm = 0;
    uint16_t fw[2];
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REG_FERR_MAX, 2, fw, &exc), EF_OK);
    fm = ef_mb_get_f32(fw);
    EF_CHECK(fm > 0 && fm == dev->drv.ferr_max);

    /* Full ring: 16 accepted, the 17th is busy. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_QUICK_STOP, &exc), EF_OK);
    EF_CHECK_EQ(dev->drv.state, EF_DRV_ENABLED);
    ef_vec3_t at = dev->drv.cmd;
    uint32_t s0 = dev->drv.next_seq;
    for (uint32_t i = 0; i < EF_DRIVE_SLOTS; i++) {
        ef_move_t m = mk_line(s0 + i, at, ef_v3(at.x - 1, at.y, at.z), LAW_DECEL);
        EF_CHECK_EQ(wr_slot(dev, (s0 + i) % EF_DRIVE_SLOTS, &m, &exc), EF_OK);
        at.x -= 1;
    }
    ef_move_t m17 = mk_line(s0 + EF_DRIVE_SLOTS, at, ef_v3(at.x - 1, at.y, at.z), LAW_DECEL);
    EF_CHECK_EQ(wr_slot(dev, s0 % EF_DRIVE_SLOTS, &m17, &exc), EF_ERR_FULL);
    EF_CHECK_EQ(exc, EF_MB_EX_BUSY);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_FREE), 0);

    /* Watchdog: a RUNNING drive faults when the master goes quiet. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_WATCHDOG, 50, &exc), EF_OK);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc), EF_OK);
    int rc = EF_OK, i = 0;
    for (; i < 1000 && rc == EF_OK; i++)
        rc = ef_mbdev_process(dev, 1000, NULL);
    EF_CHECK_EQ(rc, EF_ERR_DRIVE);
    EF_CHECK(i >= 50 && i <= 52);
    EF_CHECK_EQ(dev->drv.fault, EF_DRV_FAULT_WATCHDOG);
    for (int k = 0; k < 200; k++)
        ef_mbdev_process(dev, 1000, NULL);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_STATE), EF_DRV_FAULT);
    EF_CHECK(rd16(dev, EF_MB_REG_STATUS) & EF_MB_ST_FAULT);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_FAULT), EF_DRV_FAULT_WATCHDOG);
    /* Enable in FAULT is refused; a fault reset (with enable) recovers. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE, &exc), EF_ERR_STATE);
    EF_CHECK_EQ(exc, EF_MB_EX_DEVICE_FAILURE);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_FAULT_RESET | EF_MB_CTL_ENABLE, &exc), EF_OK);
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_STATE), EF_DRV_ENABLED);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_NEXT_SEQ), 0);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_SEQ), EF_MB_DONE_NONE);
    /* Traffic keeps the watchdog quiet: polling every 20 ms, no fault. */
    ef_vec3_t p = dev->drv.cmd;
    ef_move_t lg = mk_line(0, p, ef_v3(p.x + 20, p.y, p.z), LAW_DECEL);
    EF_CHECK_EQ(wr_slot(dev, 0, &lg, &exc), EF_OK);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc), EF_OK);
    rc = EF_OK;
    for (int k = 0; k < 1000; k++) {
        rc |= ef_mbdev_process(dev, 1000, NULL);
        if (k % 20 == 0)
            (void)rd16(dev, EF_MB_REG_STATUS);
    }
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_SEQ), 0);

    /* Direct mode over the registers. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_QUICK_STOP, &exc), EF_OK);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_MODE, EF_MB_MODE_DIRECT, &exc), EF_OK);
    EF_CHECK(rd16(dev, EF_MB_REG_STATUS) & EF_MB_ST_DIRECT);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc),
                EF_ERR_STATE);
    ef_mb_put_f32(&tw[2], NAN);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_TARGET, 6, tw, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    ef_mb_put_f32(&tw[2], 2.0f);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_TARGET, 6, tw, &exc), EF_OK);
    for (int k = 0; k < 500; k++)
        ef_mbdev_process(dev, 1000, NULL);
    uint16_t tr[6];
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REG_CMD, 6, tr, &exc), EF_OK);
    EF_CHECK(ef_mb_get_f32(&tr[0]) == 1.0f && ef_mb_get_f32(&tr[2]) == 2.0f &&
             ef_mb_get_f32(&tr[4]) == 3.0f);
    EF_CHECK_EQ(ef_mbdev_read(dev, EF_MB_REG_TARGET, 6, tr, &exc), EF_OK);
    EF_CHECK(memcmp(tr, tw, sizeof tw) == 0);
    EF_CHECK_EQ(ef_mbdev_read(NULL, 0, 1, tr, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_write(dev, 0x10, 1, NULL, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_process(NULL, 1, NULL), EF_ERR_ARG);
}

/* Feed hold over the register map: the HOLD control bit (a level) holds the drive on the
 * path (status HELD, still RUNNING), a control word without it resumes, the chain completes;
 * direct mode refuses it (illegal value). */
static void test_mbhold(void)
{
    ef_mbdev_t *dev = &g_dev;
    ef_servo_cfg_t c;
    ef_servo_cfg_default(&c);
    EF_CHECK_EQ(ef_mbdev_init(dev, &c, ef_v3(0, 0, 0), PERIOD_US, 9), EF_OK);
    uint8_t exc = 0xFF;
    ef_move_t mv[5];
    int n = mk_chain(mv);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE, &exc), EF_OK);
    for (int i = 0; i < n; i++)
        EF_CHECK_EQ(wr_slot(dev, (uint32_t)i, &mv[i], &exc), EF_OK);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc), EF_OK);
    for (int i = 0; i < 300; i++)
        EF_CHECK_EQ(ef_mbdev_process(dev, PERIOD_US, NULL), EF_OK);
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_HOLD, &exc), EF_OK);
    for (int i = 0; i < 200; i++)
        EF_CHECK_EQ(ef_mbdev_process(dev, PERIOD_US, NULL), EF_OK);
    uint16_t st = rd16(dev, EF_MB_REG_STATUS);
    EF_CHECK(st & EF_MB_ST_HELD);
    EF_CHECK(st & EF_MB_ST_MOVING); /* still executing a segment */
    EF_CHECK_EQ(rd16(dev, EF_MB_REG_STATE), EF_DRV_RUNNING);
    float x = dev->drv.cmd.x;
    for (int i = 0; i < 200; i++)
        EF_CHECK_EQ(ef_mbdev_process(dev, PERIOD_US, NULL), EF_OK);
    EF_CHECK(dev->drv.cmd.x == x && x > 0.0f);
    /* Any enabling write without the bit resumes. */
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, EF_MB_CTL_ENABLE | EF_MB_CTL_START, &exc), EF_OK);
    EF_CHECK(!(rd16(dev, EF_MB_REG_STATUS) & EF_MB_ST_HELD));
    for (int i = 0; i < 3000 && rd32(dev, EF_MB_REG_DONE_COUNT) < 5; i++)
        EF_CHECK_EQ(ef_mbdev_process(dev, PERIOD_US, NULL), EF_OK);
    EF_CHECK_EQ(rd32(dev, EF_MB_REG_DONE_COUNT), 5);
    EF_CHECK(dev->drv.cmd.x == 50.0f && dev->drv.cmd.y == 5.0f && dev->drv.cmd.z == 2.0f);
    EF_CHECK_EQ(dev->drv.fault, EF_DRV_FAULT_NONE);
    /* Direct mode: the bit is an illegal value. */
    uint16_t w[2] = {EF_MB_CTL_ENABLE | EF_MB_CTL_HOLD, EF_MB_MODE_DIRECT};
    EF_CHECK_EQ(wr1(dev, EF_MB_REG_CONTROL, 0, &exc), EF_OK);
    for (int i = 0; i < 100; i++)
        ef_mbdev_process(dev, PERIOD_US, NULL);
    EF_CHECK_EQ(ef_mbdev_write(dev, EF_MB_REG_CONTROL, 2, w, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"codec", test_crc},       {"codec", test_codec},      {"exec", test_init_args},
        {"exec", test_chain},      {"exec", test_push_checks}, {"exec", test_direct},
        {"exec", test_late},       {"stop", test_underrun},    {"stop", test_following},
        {"stop", test_quick_stop}, {"hold", test_hold},        {"mbdev", test_mbdev},
        {"mbdev", test_mbhold},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
