/* SPDX-License-Identifier: Apache-2.0 */
/*
 * CANopen helpers and the segment-mode codec (ef_can.h, ef_canopen.h): frame bit counts,
 * statusword decoding, position scaling, and the law/axis records through chunks and
 * reassembly, bit for bit, with lost, reordered and malformed chunks.
 */
#include <stdint.h>
#include <string.h>

#include "ef_test.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/core/ef_err.h"

static uint64_t g_rs = 0x9E3779B97F4A7C15ull;

/* xorshift64* */
static uint64_t rnd(void)
{
    g_rs ^= g_rs >> 12;
    g_rs ^= g_rs << 25;
    g_rs ^= g_rs >> 27;
    return g_rs * 2685821657736338717ull;
}

static double uni(double lo, double hi)
{
    return lo + (hi - lo) * (double)(rnd() >> 11) * (1.0 / 9007199254740992.0);
}

static uint32_t fbits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

/* A random move with every carried field set; phases randomly absent (all zero). */
static ef_move_t rnd_move(uint32_t seq)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    static const int degs[3] = {1, 3, 5};
    m.degree = (uint8_t)degs[rnd() % 3];
    m.seq = seq;
    m.flags = (rnd() & 1) ? EF_MOVE_STOP_END : 0;
    m.length = (float)uni(1e-3, 1000);
    m.v_exit = (float)uni(0, 500);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        if (rnd() % 3 == 0)
            continue;
        m.law.dt[k] = (float)uni(0, 3);
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            m.law.c[k][i] = (float)uni(-1e4, 1e4);
    }
    m.duration = 0.0f;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        m.duration += m.law.dt[k];
    for (int i = 0; i <= m.degree; i++)
        m.b[i] = ef_v3((float)uni(-1e5, 1e5), (float)uni(-1, 1), (float)uni(-1e-30, 1e-30));
    return m;
}

static float axis_of(ef_vec3_t v, int a)
{
    return a == 0 ? v.x : a == 1 ? v.y : v.z;
}

/* Send a record through chunks into an assembler; EF_OK when it completes. */
static int pass_record(ef_co_asm_t *as, const uint8_t *rec, uint32_t len)
{
    int rc = EF_ERR_AGAIN;
    uint32_t n = ef_co_chunk_count(len);
    for (uint32_t k = 0; k < n; k++) {
        uint8_t d[8];
        ef_co_chunk(rec, len, k, d);
        rc = ef_co_asm_feed(as, d);
        if (k + 1 < n && rc != EF_ERR_AGAIN)
            return -1000 + rc;
    }
    return rc;
}

static void test_bits(void)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    EF_CHECK_EQ(ef_can_frame_bits(&f), 55); /* SYNC: 47 + floor(33/4) */
    f.dlc = 8;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 135); /* 111 + floor(97/4) */
    f.dlc = 6;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 115);
    f.dlc = 4;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 95);
    f.dlc = 15; /* counts as 8 */
    EF_CHECK_EQ(ef_can_frame_bits(&f), 135);
    f.dlc = 8;
    f.flags = EF_CAN_FLAG_EFF;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 131 + 29); /* 67+64, floor(117/4) */
    EF_CHECK_EQ(ef_can_frame_bits(NULL), 0);
    EF_CHECK(ef_time_reached(5u, 0xFFFFFFF0u));
    EF_CHECK(!ef_time_reached(0xFFFFFFF0u, 5u));
}

static void test_words(void)
{
    EF_CHECK_EQ(ef_co_power_state(0x0000), EF_CO_PS_NOT_READY);
    EF_CHECK_EQ(ef_co_power_state(0x0250), EF_CO_PS_SWITCH_ON_DISABLED);
    EF_CHECK_EQ(ef_co_power_state(0x0231), EF_CO_PS_READY);
    EF_CHECK_EQ(ef_co_power_state(0x0233), EF_CO_PS_SWITCHED_ON);
    EF_CHECK_EQ(ef_co_power_state(0x1637), EF_CO_PS_OP_ENABLED);
    EF_CHECK_EQ(ef_co_power_state(0x0217), EF_CO_PS_QUICK_STOP);
    EF_CHECK_EQ(ef_co_power_state(0x021F), EF_CO_PS_FAULT_REACTION);
    EF_CHECK_EQ(ef_co_power_state(0x0218), EF_CO_PS_FAULT);
    EF_CHECK(!strcmp(ef_co_abort_str(EF_CO_ABORT_NO_OBJECT),
                     "object does not exist in the object dictionary"));
    EF_CHECK(!strcmp(ef_co_abort_str(0x12345678u), "unknown abort code"));
    EF_CHECK_EQ(ef_co_emcy_of_fault(EF_DRV_FAULT_FOLLOWING), EF_CO_EMCY_FOLLOWING);
    EF_CHECK_EQ(ef_co_emcy_of_fault(EF_DRV_FAULT_INJECTED), EF_CO_EMCY_INJECTED);
    EF_CHECK(!strcmp(ef_co_power_str(99), "?"));
    EF_CHECK(strlen(ef_co_emcy_str(EF_CO_EMCY_UNDERRUN)) > 5);

    int32_t inc = 0;
    EF_CHECK_EQ(ef_co_pos_to_inc(12.34567f, 10000u, &inc), EF_OK);
    EF_CHECK_EQ(inc, 123457);
    EF_CHECK_EQ(ef_co_pos_to_inc(-0.00005f, 10000u, &inc), EF_OK);
    EF_CHECK_EQ(inc, -1);
    EF_CHECK_NEAR(ef_co_inc_to_pos(123457, 10000u), 12.3457, 1e-6);
    EF_CHECK_EQ(ef_co_pos_to_inc(3e5f, 10000u, &inc), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_co_pos_to_inc(-3e5f, 10000u, &inc), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_co_pos_to_inc(0.0f / 0.0f, 10000u, &inc), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_co_pos_to_inc(1.0f, 0u, &inc), EF_ERR_ARG);
    EF_CHECK_EQ(ef_co_pos_to_inc(1.0f, 1u, NULL), EF_ERR_ARG);
}

/* Random moves: law + three axis records through chunks, decoded bit for bit. */
static void test_roundtrip(void)
{
    int ok = 1, n_law_chunks = 0, max_chunks = 0;
    for (int it = 0; it < 2000; it++) {
        ef_move_t m = rnd_move((uint32_t)rnd());
        uint8_t rec[EF_CO_REC_MAX];
        uint32_t len = 0;
        ef_co_asm_t al, ax;
        ef_co_asm_init(&al, 1);
        ef_co_asm_init(&ax, 0);
        EF_CHECK_EQ(ef_co_law_encode(&m, rec, &len), EF_OK);
        n_law_chunks += (int)ef_co_chunk_count(len);
        if ((int)ef_co_chunk_count(len) > max_chunks)
            max_chunks = (int)ef_co_chunk_count(len);
        ok &= pass_record(&al, rec, len) == EF_OK && al.rec_len == len;
        ef_move_t r;
        memset(&r, 0, sizeof r);
        ok &= ef_co_law_decode(al.rec, al.rec_len, &r) == EF_OK;
        ok &= r.seq == (m.seq & 0xFFFFu) && r.flags == m.flags &&
              fbits(r.length) == fbits(m.length) && fbits(r.v_exit) == fbits(m.v_exit) &&
              fbits(r.duration) == fbits(m.duration);
        for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
            ok &= fbits(r.law.dt[k]) == fbits(m.law.dt[k]);
            for (int j = 0; j < EF_TIMELAW_COEFFS; j++)
                ok &= fbits(r.law.c[k][j]) == fbits(m.law.c[k][j]);
        }
        for (int a = 0; a < 3; a++) {
            EF_CHECK_EQ(ef_co_axis_encode(&m, a, rec, &len), EF_OK);
            ok &= len == 8u + 4u * m.degree;
            ok &= pass_record(&ax, rec, len) == EF_OK;
            ef_move_t q;
            uint16_t s16 = 0;
            memset(&q, 0, sizeof q);
            ok &= ef_co_axis_decode(ax.rec, ax.rec_len, &q, &s16) == EF_OK;
            ok &= s16 == (uint16_t)m.seq && q.degree == m.degree;
            for (int i = 0; i <= m.degree; i++)
                ok &= fbits(q.b[i].x) == fbits(axis_of(m.b[i], a)) && q.b[i].y == 0.0f &&
                      q.b[i].z == 0.0f;
        }
    }
    EF_CHECK(ok);
    EF_CHECK(max_chunks <= (int)EF_CO_CHUNKS_MAX);
    printf("roundtrip: 2000 moves bit-exact; law chunks mean %.2f, max %d\n", n_law_chunks / 2000.0,
           max_chunks);
}

/* Lost, repeated, foreign-sequence and malformed chunks: the record is dropped, never
 * assembled wrong, and the next whole record passes. */
static void test_loss(void)
{
    ef_move_t m = rnd_move(0x1235);
    m.degree = 5;
    for (int i = 0; i <= 5; i++)
        m.b[i] = ef_v3((float)i, 2.0f * (float)i, 0);
    uint8_t rec[EF_CO_REC_MAX], d[8];
    uint32_t len = 0;
    ef_co_axis_encode(&m, 1, rec, &len);
    uint32_t n = ef_co_chunk_count(len);
    EF_CHECK_EQ(n, 4);
    ef_co_asm_t a;
    ef_co_asm_init(&a, 0);
    /* chunk 2 lost */
    ef_co_chunk(rec, len, 0, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_AGAIN);
    ef_co_chunk(rec, len, 1, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_AGAIN);
    ef_co_chunk(rec, len, 3, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_SEQ);
    /* idle until a chunk 0: later chunks ignored */
    ef_co_chunk(rec, len, 3, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_AGAIN);
    EF_CHECK_EQ(pass_record(&a, rec, len), EF_OK);
    /* a chunk 0 in the middle restarts (the partial record dropped) */
    ef_co_chunk(rec, len, 0, d);
    ef_co_asm_feed(&a, d);
    ef_co_chunk(rec, len, 1, d);
    ef_co_asm_feed(&a, d);
    ef_co_chunk(rec, len, 0, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_SEQ);
    for (uint32_t k = 1; k < n; k++) {
        ef_co_chunk(rec, len, k, d);
        int rc = ef_co_asm_feed(&a, d);
        EF_CHECK_EQ(rc, k + 1 == n ? EF_OK : EF_ERR_AGAIN);
    }
    /* a chunk of another record (sequence bits) in the middle */
    ef_move_t m2 = m;
    m2.seq = 0x1236;
    uint8_t rec2[EF_CO_REC_MAX];
    uint32_t len2;
    ef_co_axis_encode(&m2, 1, rec2, &len2);
    ef_co_chunk(rec, len, 0, d);
    ef_co_asm_feed(&a, d);
    ef_co_chunk(rec2, len2, 1, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_SEQ);
    /* a repeated chunk */
    ef_co_chunk(rec, len, 0, d);
    ef_co_asm_feed(&a, d);
    ef_co_chunk(rec, len, 1, d);
    ef_co_asm_feed(&a, d);
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_SEQ);
    /* impossible degree / phase mask / sequence bits not matching the record's seq */
    ef_co_chunk(rec, len, 0, d);
    d[3] = 4;
    EF_CHECK_EQ(ef_co_asm_feed(&a, d), EF_ERR_PROTO);
    ef_co_asm_t l;
    ef_co_asm_init(&l, 1);
    ef_co_law_encode(&m, rec, &len);
    ef_co_chunk(rec, len, 0, d);
    d[4] = 1u << EF_TIMELAW_PHASES; /* a phase that does not exist */
    EF_CHECK_EQ(ef_co_asm_feed(&l, d), EF_ERR_PROTO);
    ef_co_chunk(rec, len, 0, d);
    d[0] ^= 1u << EF_CO_CHUNK_INDEX_BITS; /* the sequence bits no longer match */
    EF_CHECK_EQ(ef_co_asm_feed(&l, d), EF_ERR_PROTO);
    EF_CHECK_EQ(pass_record(&l, rec, len), EF_OK);
    EF_CHECK_EQ(ef_co_asm_feed(NULL, d), EF_ERR_ARG);
}

/* Decoders refuse what no encoder makes. */
static void test_decode_bad(void)
{
    ef_move_t m = rnd_move(7), r;
    uint8_t rec[EF_CO_REC_MAX];
    uint32_t len = 0;
    uint16_t s16;
    m.degree = 3;
    ef_co_axis_encode(&m, 0, rec, &len);
    EF_CHECK_EQ(ef_co_axis_decode(rec, len - 1, &r, &s16), EF_ERR_ARG);
    float nan = 0.0f / 0.0f;
    memcpy(rec + 8, &nan, 4);
    EF_CHECK_EQ(ef_co_axis_decode(rec, len, &r, &s16), EF_ERR_NONFINITE);
    m.degree = 2;
    EF_CHECK_EQ(ef_co_axis_encode(&m, 0, rec, &len), EF_ERR_ARG);
    m.degree = 1;
    EF_CHECK_EQ(ef_co_axis_encode(&m, EF_AXES, rec, &len), EF_ERR_ARG);
    EF_CHECK_EQ(ef_co_axis_encode(&m, -1, rec, &len), EF_ERR_ARG);
    /* an auxiliary axis's record carries ab[k], decoded as the drive's one axis */
    m.ab[EF_AUX - 1][0] = 12.5f;
    m.ab[EF_AUX - 1][1] = -7.25f;
    EF_CHECK_EQ(ef_co_axis_encode(&m, EF_AXES - 1, rec, &len), EF_OK);
    EF_CHECK_EQ(ef_co_axis_decode(rec, len, &r, &s16), EF_OK);
    EF_CHECK(r.b[0].x == 12.5f && r.b[1].x == -7.25f && r.degree == 1);
    m.law.dt[0] = 1.0f;
    ef_co_law_encode(&m, rec, &len);
    EF_CHECK_EQ(ef_co_law_decode(rec, len + 24, &r), EF_ERR_ARG);
    memcpy(rec + 4, &nan, 4);
    EF_CHECK_EQ(ef_co_law_decode(rec, len, &r), EF_ERR_NONFINITE);
    rec[3] = 8;
    EF_CHECK_EQ(ef_co_law_decode(rec, len, &r), EF_ERR_ARG);
    EF_CHECK_EQ(ef_co_law_decode(NULL, len, &r), EF_ERR_ARG);
    /* random chunk noise never completes a record that then fails to decode silently */
    ef_co_asm_t a, l;
    ef_co_asm_init(&a, 0);
    ef_co_asm_init(&l, 1);
    int bad = 0;
    for (int it = 0; it < 200000; it++) {
        uint8_t d[8];
        uint64_t x = rnd();
        memcpy(d, &x, 8);
        if (rnd() % 2)
            d[0] &= 0xF3u; /* more chunk indices 0..3 */
        if (ef_co_asm_feed(&a, d) == EF_OK) {
            int rc = ef_co_axis_decode(a.rec, a.rec_len, &r, &s16);
            bad += rc != EF_OK && rc != EF_ERR_NONFINITE;
        }
        if (ef_co_asm_feed(&l, d) == EF_OK) {
            int rc = ef_co_law_decode(l.rec, l.rec_len, &r);
            bad += rc != EF_OK && rc != EF_ERR_NONFINITE;
        }
    }
    EF_CHECK_EQ(bad, 0);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"bits", test_bits},  {"words", test_words},      {"codec", test_roundtrip},
        {"codec", test_loss}, {"codec", test_decode_bad},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
