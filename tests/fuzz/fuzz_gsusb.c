/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target for what a USB-CAN adapter sends the host (ef_gsusb_wire.h): IN
 * transfers decoded as host frames, and the replies to DEVICE_CONFIG, BT_CONST, GET_STATE
 * and TIMESTAMP, plus the bit-timing search over whatever constants a device reports.
 * The first input byte picks the decoder and its parameters; the rest is the device's
 * bytes, copied to a buffer of exactly that size so that a read past it is an
 * AddressSanitizer report.
 *
 * Invariants (a broken one aborts, saving the input):
 *  - a decoded frame has dlc <= 8, a channel below the device's, and data past dlc zero;
 *    encoding it again gives the bytes it came from (less reserved byte and padding);
 *  - a decoded BT_CONST has non-empty ranges, and a bit timing found on it lies inside
 *    them and is within 0.5 % of the bitrate asked;
 *  - a decoded DEVICE_CONFIG has 1..EF_GSUSB_MAX_CHANNELS channels.
 *
 * Built with -DEF_FUZZ_REPLAY_MAIN it is a plain-C replay driver (gsusb_fuzz_replay
 * DIR|FILE...): "ok-*" seeds must decode, "bad-*" seeds must be refused.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/host/can/ef_gsusb_wire.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Report and crash, so the input is saved as a reproducer. */
static void fz_fail(const char *what, long a)
{
    fprintf(stderr, "gs_usb fuzz invariant broken: %s (%ld)\n", what, a);
    abort();
}

/* A frame decode with parameters from sel: bit 0 timestamps, bit 1 padding to 32 or 64
 * bytes (bit 2), bits 3-5 channels - 1. */
static int fz_frame(uint8_t sel, const uint8_t *b, size_t n, ef_msg_t *m)
{
    int with_ts = sel & 1;
    size_t pad = (sel & 2) ? ((sel & 4) ? 64u : 32u) : 0u;
    unsigned channels = 1u + ((sel >> 3) & 7u);
    ef_gsusb_frame_t f;
    int rc = ef_gsusb_frame_decode(b, n, with_ts, pad, channels, &f, m);
    if (rc != EF_OK)
        return rc;
    if (f.dlc > 8)
        fz_fail("frame dlc", f.dlc);
    if (f.channel >= channels)
        fz_fail("frame channel", f.channel);
    for (unsigned k = f.dlc; k < 8; k++)
        if (f.data[k])
            fz_fail("data past dlc", (long)k);
    uint8_t out[EF_GSUSB_FRAME_TS_LEN];
    size_t len = ef_gsusb_frame_encode(&f, out);
    if (len != (with_ts ? EF_GSUSB_FRAME_TS_LEN : EF_GSUSB_FRAME_LEN))
        fz_fail("re-encoded length", (long)len);
    /* Reserved byte 11 and data bytes past dlc are the device's to fill: not compared. */
    if (memcmp(out, b, 11) || memcmp(out + 12, b + 12, f.dlc) ||
        (with_ts && memcmp(out + 20, b + 20, 4)))
        fz_fail("frame does not re-encode to its bytes", 0);
    return EF_OK;
}

/* BT_CONST, then a bit timing for a bitrate from the input's first bytes. */
static int fz_btconst(const uint8_t *b, size_t n, ef_msg_t *m)
{
    ef_gsusb_btconst_t c;
    int rc = ef_gsusb_btconst_decode(b, n, &c, m);
    if (rc != EF_OK)
        return rc;
    if (!c.fclk || !c.tseg1_min || c.tseg1_min > c.tseg1_max || !c.tseg2_min ||
        c.tseg2_min > c.tseg2_max || !c.sjw_max || !c.brp_min || c.brp_min > c.brp_max ||
        !c.brp_inc)
        fz_fail("BT_CONST accepted with an empty range", 0);
    /* The bitrate asked: the reply's first word folded into 1..1 Mbit/s, sometimes a
     * standard one. */
    static const uint32_t std_rates[] = {1000000, 800000, 500000, 250000, 125000, 50000, 10000};
    uint32_t w = ef_gsusb_get32(b);
    uint32_t rate = (w & 0x80u) ? std_rates[w % 7u] : 1u + w % 1000000u;
    ef_gsusb_bittiming_t bt;
    uint32_t actual = 0;
    uint16_t sp = 0;
    ef_msg_t m2;
    if (ef_gsusb_bittiming_calc(&c, rate, &bt, &actual, &sp, &m2) != EF_OK)
        return EF_OK; /* a device that cannot make it is a correct answer */
    if (bt.phase_seg1 < c.tseg1_min || bt.phase_seg1 > c.tseg1_max || bt.phase_seg2 < c.tseg2_min ||
        bt.phase_seg2 > c.tseg2_max || bt.sjw > c.sjw_max || bt.sjw == 0 || bt.brp < c.brp_min ||
        bt.brp > c.brp_max || (bt.brp - c.brp_min) % c.brp_inc)
        fz_fail("bit timing outside the device's ranges", (long)bt.brp);
    double tq = 1.0 + bt.prop_seg + bt.phase_seg1 + bt.phase_seg2;
    double got = (double)c.fclk / (tq * bt.brp);
    if (got < rate * (0.995 - 1e-12) || got > rate * (1.005 + 1e-12))
        fz_fail("bit timing off the bitrate by more than 0.5 %", (long)got);
    if (sp == 0 || sp >= 1000)
        fz_fail("sample point", sp);
    return EF_OK;
}

/* One input; EF_OK when the device's bytes were accepted. */
static int fz_run(const uint8_t *data, size_t size, ef_msg_t *m)
{
    if (size < 1)
        return EF_ERR_ARG;
    uint8_t sel = data[0];
    size_t n = size - 1;
    /* Exactly n bytes on the heap: ASan sees any read past the device's reply. */
    uint8_t *b = malloc(n ? n : 1);
    if (!b)
        return EF_ERR_NOMEM;
    memcpy(b, data + 1, n);
    int rc;
    switch (sel >> 6) {
    case 0:
        rc = fz_frame(sel, b, n, m);
        break;
    case 1:
        rc = fz_btconst(b, n, m);
        break;
    case 2: {
        ef_gsusb_devcfg_t c;
        rc = ef_gsusb_devcfg_decode(b, n, &c, m);
        if (rc == EF_OK && (c.channels < 1 || c.channels > EF_GSUSB_MAX_CHANNELS))
            fz_fail("DEVICE_CONFIG channels", c.channels);
        break;
    }
    default: {
        ef_gsusb_state_t st;
        uint32_t v;
        rc = (sel & 1) ? ef_gsusb_state_decode(b, n, &st, m)
                       : ef_gsusb_u32_decode(b, n, "TIMESTAMP", &v, m);
        if (rc == EF_OK && (sel & 1) && st.state > EF_GSUSB_STATE_SLEEPING)
            fz_fail("GET_STATE state", (long)st.state);
        break;
    }
    }
    free(b);
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ef_msg_t m;
    fz_run(data, size, &m);
    return 0;
}

#ifdef EF_FUZZ_REPLAY_MAIN
#include "replay.h"

static int replay_gsusb(const uint8_t *buf, size_t len, char *why, size_t why_len)
{
    ef_msg_t m = {{0}};
    int rc = fz_run(buf, len, &m);
    if (rc != EF_OK)
        snprintf(why, why_len, "%.200s", m.text);
    return rc != EF_OK;
}

int main(int argc, char **argv)
{
    return ef_replay_main(argc, argv, replay_gsusb);
}
#endif
