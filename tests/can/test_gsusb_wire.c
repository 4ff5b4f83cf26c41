/* SPDX-License-Identifier: Apache-2.0 */
/* The gs_usb codec (ef_gsusb_wire.h): byte layouts against the protocol's, refusals of
 * short, oversized and out-of-range replies with the request named, and the bit-timing
 * search against the CiA 301 sample points and the device's ranges. */
#include <stdint.h>
#include <string.h>

#include "ef_test.h"
#include "evenfeed/host/can/ef_gsusb_wire.h"

/* candleLight on an STM32F072: 48 MHz, the bxCAN's ranges. */
static const ef_gsusb_btconst_t wt_candle = {EF_GSUSB_FEAT_LISTEN_ONLY | EF_GSUSB_FEAT_LOOP_BACK |
                                                 EF_GSUSB_FEAT_HW_TIMESTAMP,
                                             48000000u,
                                             1,
                                             16,
                                             1,
                                             8,
                                             4,
                                             1,
                                             1024,
                                             1};

/* Frames: the 20- and 24-byte layouts, reserved and unused data zeroed on encode. */
static void test_frame(void)
{
    ef_gsusb_frame_t f;
    memset(&f, 0xAA, sizeof f); /* garbage everywhere the encoder must not copy */
    f.echo_id = 7;
    f.can_id = 0x181;
    f.dlc = 3;
    f.channel = 0;
    f.flags = 0;
    f.has_ts = 0;
    f.data[0] = 1, f.data[1] = 2, f.data[2] = 3;
    uint8_t b[24];
    memset(b, 0x55, sizeof b);
    EF_CHECK_EQ(ef_gsusb_frame_encode(&f, b), 20);
    static const uint8_t want[20] = {7, 0, 0, 0, 0x81, 1, 0, 0, 3, 0, 0, 0, 1, 2, 3, 0, 0, 0, 0, 0};
    EF_CHECK(memcmp(b, want, 20) == 0);
    EF_CHECK_EQ(b[20], 0x55); /* nothing written past a 20-byte frame */
    f.has_ts = 1;
    f.ts_us = 0xFFFFFFFEu;
    EF_CHECK_EQ(ef_gsusb_frame_encode(&f, b), 24);
    EF_CHECK_EQ(ef_gsusb_get32(b + 20), 0xFFFFFFFEu);
    f.dlc = 9;
    EF_CHECK_EQ(ef_gsusb_frame_encode(&f, b), 0);

    ef_gsusb_frame_t g;
    ef_msg_t m;
    b[8] = 9; /* a device's dlc of 9 */
    EF_CHECK_EQ(ef_gsusb_frame_decode(b, 24, 1, 0, 1, &g, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "can_dlc 9") != NULL);
    b[8] = 3;
    EF_CHECK_EQ(ef_gsusb_frame_decode(b, 24, 1, 0, 1, &g, &m), EF_OK);
    EF_CHECK_EQ(g.echo_id, 7);
    EF_CHECK_EQ(g.can_id, 0x181);
    EF_CHECK_EQ(g.ts_us, 0xFFFFFFFEu);
    EF_CHECK(g.has_ts && g.data[2] == 3 && g.data[3] == 0);
    /* Lengths: 24 without timestamps, 20 with, 19, padding only when asked. */
    EF_CHECK_EQ(ef_gsusb_frame_decode(b, 24, 0, 0, 1, &g, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "24 bytes, want 20") != NULL);
    EF_CHECK_EQ(ef_gsusb_frame_decode(b, 20, 1, 0, 1, &g, &m), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_gsusb_frame_decode(b, 19, 0, 0, 1, &g, &m), EF_ERR_PROTO);
    uint8_t pad[64];
    memset(pad, 0, sizeof pad);
    memcpy(pad, b, 20);
    EF_CHECK_EQ(ef_gsusb_frame_decode(pad, 64, 0, 64, 1, &g, &m), EF_OK);
    EF_CHECK_EQ(ef_gsusb_frame_decode(pad, 63, 0, 64, 1, &g, &m), EF_ERR_PROTO);
    EF_CHECK_EQ(ef_gsusb_frame_decode(pad, 64, 0, 0, 1, &g, &m), EF_ERR_PROTO);
    /* Channel: the device's count bounds it. */
    pad[9] = 1;
    EF_CHECK_EQ(ef_gsusb_frame_decode(pad, 20, 0, 0, 1, &g, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "channel 1 (the device has 1)") != NULL);
    EF_CHECK_EQ(ef_gsusb_frame_decode(pad, 20, 0, 0, 2, &g, &m), EF_OK);
    EF_CHECK_EQ(ef_gsusb_frame_decode(NULL, 20, 0, 0, 2, &g, &m), EF_ERR_ARG);
}

/* Replies: exact sizes, the request named, fields checked. */
static void test_replies(void)
{
    uint8_t b[64];
    ef_msg_t m;
    ef_gsusb_devcfg_t dc = {3, 0x20, 0x10}, dc2;
    EF_CHECK_EQ(ef_gsusb_devcfg_encode(&dc, b), 12);
    EF_CHECK_EQ(b[3], 2); /* icount = channels - 1 */
    EF_CHECK_EQ(ef_gsusb_devcfg_decode(b, 12, &dc2, &m), EF_OK);
    EF_CHECK(dc2.channels == 3 && dc2.sw_version == 0x20 && dc2.hw_version == 0x10);
    EF_CHECK_EQ(ef_gsusb_devcfg_decode(b, 11, &dc2, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "DEVICE_CONFIG: short reply of 11 bytes, want 12") != NULL);
    EF_CHECK_EQ(ef_gsusb_devcfg_decode(b, 64, &dc2, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "oversized reply of 64 bytes") != NULL);
    b[3] = 255;
    EF_CHECK_EQ(ef_gsusb_devcfg_decode(b, 12, &dc2, &m), EF_ERR_PROTO);

    ef_gsusb_btconst_t c;
    EF_CHECK_EQ(ef_gsusb_btconst_encode(&wt_candle, b), 40);
    EF_CHECK_EQ(ef_gsusb_get32(b + 4), 48000000u);
    EF_CHECK_EQ(ef_gsusb_btconst_decode(b, 40, &c, &m), EF_OK);
    EF_CHECK(memcmp(&c, &wt_candle, sizeof c) == 0);
    EF_CHECK_EQ(ef_gsusb_btconst_decode(b, 20, &c, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "BT_CONST: short reply of 20 bytes") != NULL);
    ef_gsusb_put32(b + 32, 0); /* brp_max 0 < brp_min */
    EF_CHECK_EQ(ef_gsusb_btconst_decode(b, 40, &c, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "brp range") != NULL);
    ef_gsusb_put32(b + 32, 1024);
    ef_gsusb_put32(b + 4, 0);
    EF_CHECK_EQ(ef_gsusb_btconst_decode(b, 40, &c, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "fclk_can 0") != NULL);

    ef_gsusb_bittiming_t bt = {0, 13, 2, 1, 6}, bt2;
    EF_CHECK_EQ(ef_gsusb_bittiming_encode(&bt, b), 20);
    EF_CHECK_EQ(ef_gsusb_bittiming_decode(b, 20, &bt2, &m), EF_OK);
    EF_CHECK(memcmp(&bt, &bt2, sizeof bt) == 0);
    EF_CHECK_EQ(ef_gsusb_bittiming_decode(b, 16, &bt2, &m), EF_ERR_PROTO);

    uint32_t md, fl;
    EF_CHECK_EQ(ef_gsusb_mode_encode(EF_GSUSB_MODE_START, EF_GSUSB_MODE_HW_TIMESTAMP, b), 8);
    EF_CHECK_EQ(ef_gsusb_mode_decode(b, 8, &md, &fl, &m), EF_OK);
    EF_CHECK(md == 1 && fl == EF_GSUSB_MODE_HW_TIMESTAMP);
    ef_gsusb_put32(b, 2);
    EF_CHECK_EQ(ef_gsusb_mode_decode(b, 8, &md, &fl, &m), EF_ERR_PROTO);

    ef_gsusb_state_t s = {EF_GSUSB_STATE_PASSIVE, 130, 5}, s2;
    EF_CHECK_EQ(ef_gsusb_state_encode(&s, b), 12);
    EF_CHECK_EQ(ef_gsusb_state_decode(b, 12, &s2, &m), EF_OK);
    EF_CHECK(s2.state == EF_GSUSB_STATE_PASSIVE && s2.rxerr == 130 && s2.txerr == 5);
    ef_gsusb_put32(b, 6);
    EF_CHECK_EQ(ef_gsusb_state_decode(b, 12, &s2, &m), EF_ERR_PROTO);

    uint32_t v;
    ef_gsusb_put32(b, 0xDEADBEEFu);
    EF_CHECK_EQ(ef_gsusb_u32_decode(b, 4, "TIMESTAMP", &v, &m), EF_OK);
    EF_CHECK_EQ(v, 0xDEADBEEFu);
    EF_CHECK_EQ(ef_gsusb_u32_decode(b, 3, "TIMESTAMP", &v, &m), EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "TIMESTAMP") != NULL);
    EF_CHECK(strcmp(ef_gsusb_req_name(EF_GSUSB_BREQ_BT_CONST), "BT_CONST") == 0);
    EF_CHECK(strcmp(ef_gsusb_req_name(99), "unknown request") == 0);
}

/* Bit timing: the usual CANopen bitrates exactly, at CiA 301's sample points, inside the
 * device's ranges; a bitrate the device cannot make refused with the nearest it can. */
static void test_bittiming(void)
{
    static const struct {
        uint32_t rate, sp;
    } cases[] = {{1000000, 750}, {800000, 800}, {500000, 875}, {250000, 875},
                 {125000, 875},  {50000, 875},  {20000, 875},  {10000, 875}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        ef_gsusb_bittiming_t bt;
        uint32_t got = 0;
        uint16_t sp = 0;
        ef_msg_t m;
        EF_CHECK_EQ(ef_gsusb_bittiming_calc(&wt_candle, cases[k].rate, &bt, &got, &sp, &m), EF_OK);
        EF_CHECK_EQ(got, cases[k].rate);
        EF_CHECK_EQ(ef_gsusb_bitrate(wt_candle.fclk, &bt), cases[k].rate);
        EF_CHECK_EQ(sp, cases[k].sp);
        EF_CHECK(bt.phase_seg1 >= 1 && bt.phase_seg1 <= 16 && bt.phase_seg2 >= 1 &&
                 bt.phase_seg2 <= 8 && bt.sjw >= 1 && bt.sjw <= 4 && bt.brp <= 1024);
    }
    /* 1 Mbit/s at 48 MHz: 16 quanta of 3 clocks, sample point at 12 of them. */
    ef_gsusb_bittiming_t bt;
    ef_msg_t m;
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&wt_candle, 1000000, &bt, NULL, NULL, &m), EF_OK);
    EF_CHECK(bt.brp == 3 && bt.phase_seg1 == 11 && bt.phase_seg2 == 4 && bt.sjw == 4);
    /* 1 kbit/s needs a prescaler of 1920 at 25 quanta: beyond 1024. */
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&wt_candle, 1000, &bt, NULL, NULL, &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "cannot make 1000 bit/s") && strstr(m.text, "nearest is 1875"));
    /* An 8 MHz clock makes 1 Mbit/s with 8 quanta, 75 %. */
    ef_gsusb_btconst_t c8 = {0, 8000000u, 1, 16, 1, 8, 1, 1, 64, 1};
    uint16_t sp = 0;
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&c8, 1000000, &bt, NULL, &sp, &m), EF_OK);
    EF_CHECK(bt.brp == 1 && bt.phase_seg1 + bt.phase_seg2 == 7 && sp == 750 && bt.sjw == 1);
    /* A clock no prescaler divides closely enough: 16.5 MHz at 1 Mbit/s is 16.5 quanta. */
    ef_gsusb_btconst_t c16 = {0, 16500000u, 1, 16, 1, 8, 4, 1, 1, 1};
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&c16, 1000000, &bt, NULL, NULL, &m), EF_ERR_IO);
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&wt_candle, 0, &bt, NULL, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&wt_candle, 2000000, &bt, NULL, NULL, &m), EF_ERR_ARG);
    /* A prescaler step of 2 from 2 (even prescalers only) is honoured. */
    ef_gsusb_btconst_t c2 = {0, 80000000u, 2, 256, 2, 128, 128, 2, 512, 2};
    EF_CHECK_EQ(ef_gsusb_bittiming_calc(&c2, 500000, &bt, NULL, NULL, &m), EF_OK);
    EF_CHECK(bt.brp % 2 == 0 && ef_gsusb_bitrate(c2.fclk, &bt) == 500000u);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"frame", test_frame},
        {"replies", test_replies},
        {"bittiming", test_bittiming},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
