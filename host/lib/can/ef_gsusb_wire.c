/* SPDX-License-Identifier: Apache-2.0 */
/* The gs_usb protocol on byte buffers: requests' structures, the host frame, bit timing
 * (ef_gsusb_wire.h). Every decoder checks the length first and reads nothing past it. */
#include <string.h>

#include "evenfeed/host/can/ef_gsusb_wire.h"

uint32_t ef_gsusb_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

void ef_gsusb_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

const char *ef_gsusb_req_name(unsigned breq)
{
    switch (breq) {
    case EF_GSUSB_BREQ_HOST_FORMAT:
        return "HOST_FORMAT";
    case EF_GSUSB_BREQ_BITTIMING:
        return "BITTIMING";
    case EF_GSUSB_BREQ_MODE:
        return "MODE";
    case EF_GSUSB_BREQ_BERR:
        return "BERR";
    case EF_GSUSB_BREQ_BT_CONST:
        return "BT_CONST";
    case EF_GSUSB_BREQ_DEVICE_CONFIG:
        return "DEVICE_CONFIG";
    case EF_GSUSB_BREQ_TIMESTAMP:
        return "TIMESTAMP";
    case EF_GSUSB_BREQ_IDENTIFY:
        return "IDENTIFY";
    case EF_GSUSB_BREQ_GET_STATE:
        return "GET_STATE";
    default:
        return "unknown request";
    }
}

/* A reply or payload must be exactly `want` bytes: a short one leaves fields unset, a long
 * one is not the structure the request defines (a device of another protocol, or a bug). */
static int gsw_len(size_t n, size_t want, const char *what, ef_msg_t *m)
{
    if (n != want)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb %s: %s of %zu bytes, want %zu", what,
                       n < want ? "short reply" : "oversized reply", n, want);
    return EF_OK;
}

int ef_gsusb_devcfg_decode(const uint8_t *buf, size_t n, ef_gsusb_devcfg_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb DEVICE_CONFIG: NULL");
    int rc = gsw_len(n, EF_GSUSB_DEVCFG_LEN, "DEVICE_CONFIG", m);
    if (rc != EF_OK)
        return rc;
    unsigned ch = (unsigned)buf[3] + 1u;
    if (ch > EF_GSUSB_MAX_CHANNELS)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb DEVICE_CONFIG: %u channels (at most %u)", ch,
                       EF_GSUSB_MAX_CHANNELS);
    out->channels = (uint8_t)ch;
    out->sw_version = ef_gsusb_get32(buf + 4);
    out->hw_version = ef_gsusb_get32(buf + 8);
    return EF_OK;
}

size_t ef_gsusb_devcfg_encode(const ef_gsusb_devcfg_t *c, uint8_t *out)
{
    memset(out, 0, EF_GSUSB_DEVCFG_LEN);
    out[3] = (uint8_t)(c->channels ? c->channels - 1u : 0u);
    ef_gsusb_put32(out + 4, c->sw_version);
    ef_gsusb_put32(out + 8, c->hw_version);
    return EF_GSUSB_DEVCFG_LEN;
}

int ef_gsusb_btconst_decode(const uint8_t *buf, size_t n, ef_gsusb_btconst_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb BT_CONST: NULL");
    int rc = gsw_len(n, EF_GSUSB_BTCONST_LEN, "BT_CONST", m);
    if (rc != EF_OK)
        return rc;
    ef_gsusb_btconst_t c;
    uint32_t *f[] = {&c.feature,   &c.fclk,    &c.tseg1_min, &c.tseg1_max, &c.tseg2_min,
                     &c.tseg2_max, &c.sjw_max, &c.brp_min,   &c.brp_max,   &c.brp_inc};
    for (size_t k = 0; k < sizeof f / sizeof f[0]; k++)
        *f[k] = ef_gsusb_get32(buf + 4 * k);
    /* Ranges the bit-timing search relies on: a zero minimum or an empty range would make
     * it divide by zero or find nothing for a reason the user could not see. */
    const char *bad = NULL;
    if (c.fclk == 0)
        bad = "fclk_can 0";
    else if (c.tseg1_min == 0 || c.tseg1_min > c.tseg1_max)
        bad = "tseg1 range empty or from 0";
    else if (c.tseg2_min == 0 || c.tseg2_min > c.tseg2_max)
        bad = "tseg2 range empty or from 0";
    else if (c.sjw_max == 0)
        bad = "sjw_max 0";
    else if (c.brp_min == 0 || c.brp_min > c.brp_max)
        bad = "brp range empty or from 0";
    else if (c.brp_inc == 0)
        bad = "brp_inc 0";
    if (bad)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb BT_CONST: %s", bad);
    *out = c;
    return EF_OK;
}

size_t ef_gsusb_btconst_encode(const ef_gsusb_btconst_t *c, uint8_t *out)
{
    const uint32_t v[] = {c->feature,   c->fclk,    c->tseg1_min, c->tseg1_max, c->tseg2_min,
                          c->tseg2_max, c->sjw_max, c->brp_min,   c->brp_max,   c->brp_inc};
    for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
        ef_gsusb_put32(out + 4 * k, v[k]);
    return EF_GSUSB_BTCONST_LEN;
}

size_t ef_gsusb_bittiming_encode(const ef_gsusb_bittiming_t *bt, uint8_t *out)
{
    ef_gsusb_put32(out, bt->prop_seg);
    ef_gsusb_put32(out + 4, bt->phase_seg1);
    ef_gsusb_put32(out + 8, bt->phase_seg2);
    ef_gsusb_put32(out + 12, bt->sjw);
    ef_gsusb_put32(out + 16, bt->brp);
    return EF_GSUSB_BITTIME_LEN;
}

int ef_gsusb_bittiming_decode(const uint8_t *buf, size_t n, ef_gsusb_bittiming_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb BITTIMING: NULL");
    int rc = gsw_len(n, EF_GSUSB_BITTIME_LEN, "BITTIMING", m);
    if (rc != EF_OK)
        return rc;
    out->prop_seg = ef_gsusb_get32(buf);
    out->phase_seg1 = ef_gsusb_get32(buf + 4);
    out->phase_seg2 = ef_gsusb_get32(buf + 8);
    out->sjw = ef_gsusb_get32(buf + 12);
    out->brp = ef_gsusb_get32(buf + 16);
    return EF_OK;
}

size_t ef_gsusb_mode_encode(uint32_t mode, uint32_t flags, uint8_t *out)
{
    ef_gsusb_put32(out, mode);
    ef_gsusb_put32(out + 4, flags);
    return EF_GSUSB_MODE_LEN;
}

int ef_gsusb_mode_decode(const uint8_t *buf, size_t n, uint32_t *mode, uint32_t *flags, ef_msg_t *m)
{
    if (!buf || !mode || !flags)
        return ef_fail(m, EF_ERR_ARG, "gs_usb MODE: NULL");
    int rc = gsw_len(n, EF_GSUSB_MODE_LEN, "MODE", m);
    if (rc != EF_OK)
        return rc;
    uint32_t md = ef_gsusb_get32(buf);
    if (md != EF_GSUSB_MODE_RESET && md != EF_GSUSB_MODE_START)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb MODE: mode %u is neither reset (0) nor start (1)",
                       md);
    *mode = md;
    *flags = ef_gsusb_get32(buf + 4);
    return EF_OK;
}

int ef_gsusb_state_decode(const uint8_t *buf, size_t n, ef_gsusb_state_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb GET_STATE: NULL");
    int rc = gsw_len(n, EF_GSUSB_STATE_LEN, "GET_STATE", m);
    if (rc != EF_OK)
        return rc;
    uint32_t st = ef_gsusb_get32(buf);
    if (st > EF_GSUSB_STATE_SLEEPING)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb GET_STATE: state %u unknown", st);
    out->state = st;
    out->rxerr = ef_gsusb_get32(buf + 4);
    out->txerr = ef_gsusb_get32(buf + 8);
    return EF_OK;
}

size_t ef_gsusb_state_encode(const ef_gsusb_state_t *s, uint8_t *out)
{
    ef_gsusb_put32(out, s->state);
    ef_gsusb_put32(out + 4, s->rxerr);
    ef_gsusb_put32(out + 8, s->txerr);
    return EF_GSUSB_STATE_LEN;
}

int ef_gsusb_u32_decode(const uint8_t *buf, size_t n, const char *what, uint32_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb %s: NULL", what ? what : "?");
    int rc = gsw_len(n, EF_GSUSB_U32_LEN, what ? what : "?", m);
    if (rc != EF_OK)
        return rc;
    *out = ef_gsusb_get32(buf);
    return EF_OK;
}

size_t ef_gsusb_frame_encode(const ef_gsusb_frame_t *f, uint8_t *out)
{
    if (f->dlc > 8)
        return 0;
    ef_gsusb_put32(out, f->echo_id);
    ef_gsusb_put32(out + 4, f->can_id);
    out[8] = f->dlc;
    out[9] = f->channel;
    out[10] = f->flags;
    out[11] = 0; /* reserved: devices may give it a meaning some day, so always 0 */
    memset(out + 12, 0, 8);
    memcpy(out + 12, f->data, f->dlc);
    if (!f->has_ts)
        return EF_GSUSB_FRAME_LEN;
    ef_gsusb_put32(out + 20, f->ts_us);
    return EF_GSUSB_FRAME_TS_LEN;
}

int ef_gsusb_frame_decode(const uint8_t *buf, size_t n, int with_ts, size_t pad_to,
                          unsigned channels, ef_gsusb_frame_t *out, ef_msg_t *m)
{
    if (!buf || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb frame: NULL");
    size_t want = with_ts ? EF_GSUSB_FRAME_TS_LEN : EF_GSUSB_FRAME_LEN;
    /* A padded transfer is still at least one whole frame: pad_to below the frame's size is
     * no padding the decoder can use. */
    if (n != want && !(pad_to >= want && n == pad_to))
        return ef_fail(m, EF_ERR_PROTO, "gs_usb frame: %zu bytes, want %zu%s", n, want,
                       pad_to >= want ? " or the padded packet size" : "");
    uint8_t dlc = buf[8], ch = buf[9];
    if (dlc > 8)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb frame: can_dlc %u (classic CAN: 0..8)", dlc);
    if (ch >= channels)
        return ef_fail(m, EF_ERR_PROTO, "gs_usb frame: channel %u (the device has %u)", ch,
                       channels);
    out->echo_id = ef_gsusb_get32(buf);
    out->can_id = ef_gsusb_get32(buf + 4);
    out->dlc = dlc;
    out->channel = ch;
    out->flags = buf[10];
    memset(out->data, 0, sizeof out->data);
    memcpy(out->data, buf + 12, dlc);
    out->has_ts = (uint8_t)(with_ts != 0);
    out->ts_us = with_ts ? ef_gsusb_get32(buf + 20) : 0;
    return EF_OK;
}

uint32_t ef_gsusb_bitrate(uint32_t fclk, const ef_gsusb_bittiming_t *bt)
{
    uint64_t tq = 1u + (uint64_t)bt->prop_seg + bt->phase_seg1 + bt->phase_seg2;
    uint64_t div = tq * bt->brp;
    if (!bt->brp || div == 0)
        return 0;
    return (uint32_t)(((uint64_t)fclk + div / 2) / div);
}

/* CiA 301's recommended sample point for a bitrate, in 1/1000 of the bit (the values the
 * Linux kernel's can_calc_bittiming() also takes). */
static uint32_t gsw_sample_point(uint32_t bitrate)
{
    if (bitrate > 800000u)
        return 750u;
    if (bitrate > 500000u)
        return 800u;
    return 875u;
}

/* Quanta in a bit the search considers: fewer than 8 leave no room for the sample point and
 * resynchronization; more than 25 is beyond what CAN controllers count. */
#define GSW_TQ_MIN 8u
#define GSW_TQ_MAX 25u
/* The bitrate error accepted, in parts per million: 0.5 %, well inside CAN's oscillator
 * tolerance budget at 1 Mbit/s (the Linux kernel refuses above 5 %). */
#define GSW_MAX_ERR_PPM 5000u

int ef_gsusb_bittiming_calc(const ef_gsusb_btconst_t *bc, uint32_t bitrate,
                            ef_gsusb_bittiming_t *bt, uint32_t *actual, uint16_t *sp_permille,
                            ef_msg_t *m)
{
    if (!bc || !bt)
        return ef_fail(m, EF_ERR_ARG, "gs_usb bit timing: NULL");
    if (bitrate == 0 || bitrate > 1000000u)
        return ef_fail(m, EF_ERR_ARG, "gs_usb bit timing: bitrate %u (classic CAN: 1..1000000)",
                       bitrate);
    if (bc->fclk == 0 || bc->brp_inc == 0 || bc->brp_min == 0 || bc->tseg1_min == 0 ||
        bc->tseg2_min == 0)
        return ef_fail(m, EF_ERR_ARG, "gs_usb bit timing: device constants unusable");
    uint32_t sp_want = gsw_sample_point(bitrate);
    int found = 0;
    uint64_t best_err = 0, best_sp_err = 0, near_err = UINT64_MAX;
    uint32_t best_tq = 0, near_rate = 0;
    ef_gsusb_bittiming_t best = {0, 0, 0, 0, 0};
    /* Most quanta first: finer resolution of the sample point and of resynchronization. */
    for (uint32_t tq = GSW_TQ_MAX; tq >= GSW_TQ_MIN; tq--) {
        /* In 64 bits: a device may report ranges up to 2^32 - 1, whose sums wrap in 32. */
        if ((uint64_t)tq - 1u < (uint64_t)bc->tseg1_min + bc->tseg2_min ||
            (uint64_t)tq - 1u > (uint64_t)bc->tseg1_max + bc->tseg2_max)
            continue;
        /* The prescaler nearest to the exact one, rounded to the device's step, and the one
         * step either side (rounding the quotient can land on the wrong side). */
        uint64_t exact =
            ((uint64_t)bc->fclk + (uint64_t)tq * bitrate / 2u) / ((uint64_t)tq * bitrate);
        for (int d = -1; d <= 1; d++) {
            /* Clamped into the device's range: out of range it is still the nearest the
             * device can make, for the message when nothing fits. */
            int64_t b = (int64_t)exact + d * (int64_t)bc->brp_inc;
            if (b < (int64_t)bc->brp_min)
                b = bc->brp_min;
            if (b > (int64_t)bc->brp_max)
                b = bc->brp_max;
            b -= (int64_t)((uint64_t)(b - bc->brp_min) % bc->brp_inc);
            uint64_t rate = (uint64_t)bc->fclk / ((uint64_t)tq * (uint64_t)b);
            uint64_t num = (uint64_t)bc->fclk, den = (uint64_t)tq * (uint64_t)b * bitrate;
            /* |fclk / (tq b) - bitrate| / bitrate in ppm, exactly. */
            /* In double: diff * 10^6 overflows 64 bits for the prescalers a device may claim
             * (up to 2^32); ppm as an integer keeps the comparisons exact. */
            uint64_t diff = num > den ? num - den : den - num;
            double x = (double)diff * 1e6 / (double)den;
            uint64_t err = diff >= den ? 1000000u : (uint64_t)x;
            if ((double)err < x)
                err++; /* rounded up: within GSW_MAX_ERR_PPM means truly within it */
            if (err < near_err) {
                near_err = err;
                near_rate = (uint32_t)rate;
            }
            if (err > GSW_MAX_ERR_PPM)
                continue;
            /* tseg2 from the sample point, then clamp both segments into their ranges. */
            uint32_t t2 = (uint32_t)((tq * (1000u - sp_want) + 500u) / 1000u);
            if (t2 < bc->tseg2_min)
                t2 = bc->tseg2_min;
            if (t2 > bc->tseg2_max)
                t2 = bc->tseg2_max;
            uint32_t t1 = tq - 1u - t2;
            if (t1 > bc->tseg1_max) {
                t1 = bc->tseg1_max;
                t2 = tq - 1u - t1;
            }
            if (t1 < bc->tseg1_min) {
                t1 = bc->tseg1_min;
                t2 = tq - 1u - t1;
            }
            if (t2 < bc->tseg2_min || t2 > bc->tseg2_max)
                continue;
            uint32_t sp = (1000u * (1u + t1) + tq / 2u) / tq;
            uint64_t sp_err = sp > sp_want ? sp - sp_want : sp_want - sp;
            if (!found || err < best_err || (err == best_err && sp_err < best_sp_err) ||
                (err == best_err && sp_err == best_sp_err && tq > best_tq)) {
                found = 1;
                best_err = err;
                best_sp_err = sp_err;
                best_tq = tq;
                best.prop_seg = 0;
                best.phase_seg1 = t1;
                best.phase_seg2 = t2;
                best.sjw = t2 < bc->sjw_max ? t2 : bc->sjw_max;
                best.brp = (uint32_t)b;
            }
        }
    }
    if (!found) {
        if (near_rate)
            return ef_fail(m, EF_ERR_IO,
                           "gs_usb: the adapter cannot make %u bit/s (clock %u Hz, prescaler "
                           "%u..%u): the nearest is %u bit/s, %.2f %% off (at most 0.5 %%)",
                           bitrate, bc->fclk, bc->brp_min, bc->brp_max, near_rate,
                           (double)near_err / 1e4);
        return ef_fail(m, EF_ERR_IO,
                       "gs_usb: the adapter cannot make %u bit/s (clock %u Hz, prescaler "
                       "%u..%u, %llu..%llu quanta a bit)",
                       bitrate, bc->fclk, bc->brp_min, bc->brp_max,
                       (unsigned long long)(1u + (uint64_t)bc->tseg1_min + bc->tseg2_min),
                       (unsigned long long)(1u + (uint64_t)bc->tseg1_max + bc->tseg2_max));
    }
    *bt = best;
    if (actual)
        *actual = ef_gsusb_bitrate(bc->fclk, &best);
    if (sp_permille)
        *sp_permille = (uint16_t)((1000u * (1u + best.phase_seg1) + best_tq / 2u) / best_tq);
    return EF_OK;
}
