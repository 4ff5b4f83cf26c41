/* SPDX-License-Identifier: Apache-2.0 */
/* gs_usb USB-CAN adapters over libusb-1.0: the CAN transport and the adapter list
 * (ef_gsusb.h). Completions run inside recv/send/flush, in the bus thread (libusb calls
 * them from libusb_handle_events_*), so the context needs no lock. */
#include <ctype.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>

#include <libusb.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include "evenfeed/host/can/ef_gsusb.h"
#include "evenfeed/host/can/ef_sockcan.h"

/* The USB ids gs_usb firmwares use (those the Linux driver binds to). */
static const uint16_t gsu_ids[][2] = {
    {0x1d50, 0x606f}, /* candleLight, CANable (OpenMoko id) */
    {0x1209, 0x2323}, /* candleLight (pid.codes) */
    {0x1cd2, 0x606f}, /* CES CANext FD */
    {0x16d0, 0x10b8}, /* ABE CANdebugger FD */
};

#define GSU_DEFAULT_BITRATE 1000000u
#define GSU_CLOSE_WAIT_MS   1000
#define GSU_IFACE           0
#define GSU_CTRL_IN_MAX     64 /* bytes asked for by IN requests (the largest reply is 40) */
#define GSU_IN_ERRORS_MAX   8  /* bulk IN errors in a row that end the transport, */
/* ... when they also span this long: an unplug's first IN transfers fail with a transfer
 * error before the kernel has removed the device (then every transfer says NO_DEVICE), and
 * eight immediate resubmissions take well under a millisecond; under load the removal has
 * been seen to come after them, and the unplug was reported as an adapter fault. */
#define GSU_IN_ERROR_US 100000u

/* ---- Small helpers ------------------------------------------------------------------ */

static int gsu_id_known(uint16_t vid, uint16_t pid)
{
    for (size_t i = 0; i < sizeof gsu_ids / sizeof gsu_ids[0]; i++)
        if (gsu_ids[i][0] == vid && gsu_ids[i][1] == pid)
            return 1;
    return 0;
}

/* "B-P.P.P": the bus and the ports from the root, as lsusb -t and sysfs name a device;
 * stable across replugs into the same socket, unlike the device address. */
static void gsu_path(libusb_device *d, char *buf, size_t n)
{
    uint8_t ports[8];
    int np = libusb_get_port_numbers(d, ports, (int)sizeof ports);
    int k = snprintf(buf, n, "%u", (unsigned)libusb_get_bus_number(d));
    for (int i = 0; i < np && k > 0 && (size_t)k < n; i++)
        k += snprintf(buf + k, n - (size_t)k, "%c%u", i ? '.' : '-', (unsigned)ports[i]);
}

/* Whether a name is a bus path rather than a serial number. */
static int gsu_is_path(const char *s)
{
    const char *p = s;
    if (!isdigit((unsigned char)*p))
        return 0;
    while (isdigit((unsigned char)*p))
        p++;
    if (*p != '-' || !isdigit((unsigned char)p[1]))
        return 0;
    for (p++; *p; p++)
        if (!isdigit((unsigned char)*p) && *p != '.')
            return 0;
    return 1;
}

static void gsu_string(libusb_device_handle *h, uint8_t idx, char *buf, size_t n)
{
    buf[0] = 0;
    if (idx == 0 || n == 0)
        return;
    int r = libusb_get_string_descriptor_ascii(h, idx, (unsigned char *)buf, (int)n);
    if (r < 0)
        buf[0] = 0;
    else
        buf[(size_t)r < n ? (size_t)r : n - 1] = 0;
}

static uint32_t gsu_now(void)
{
    return ef_canif_host_now_us();
}

/* The udev rule's pointer, shared by open and list. */
static const char gsu_access_hint[] =
    "no permission to open the USB device: install the udev rule for gs_usb adapters "
    "(docs/can.md, 'USB-CAN adapters') or run as root";

/* ---- Options and specs -------------------------------------------------------------- */

/* Largest timeout option (ms): a minute, far beyond any adapter's answer. */
#define GSU_TIMEOUT_MAX_MS 60000u

/* The bulk OUT bound and the echo bound in force (ms). */
static unsigned gsu_out_ms(const ef_gsusb_t *g)
{
    return g->opts.timeout_ms ? (unsigned)g->opts.timeout_ms : (unsigned)EF_GSUSB_OUT_TIMEOUT_MS;
}

static uint32_t gsu_echo_ms(const ef_gsusb_t *g)
{
    return g->opts.timeout_ms ? 2u * g->opts.timeout_ms : (uint32_t)EF_GSUSB_ECHO_TIMEOUT_MS;
}

void ef_gsusb_opts_default(ef_gsusb_opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->hw_timestamps = -1;
}

void ef_gsusb_init(ef_gsusb_t *g)
{
    memset(g, 0, sizeof *g);
    ef_gsusb_opts_default(&g->opts);
    g->dev_state = -1;
    g->tec = g->rec = -1;
}

int ef_gsusb_set_opts(ef_gsusb_t *g, const ef_gsusb_opts_t *o, ef_msg_t *m)
{
    if (!g || !o)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options: NULL");
    if (g->is_open)
        return ef_fail(m, EF_ERR_STATE, "%s: options are set before open", g->label);
    if (o->channel >= EF_GSUSB_MAX_CHANNELS)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options: channel %u (0..%u)", (unsigned)o->channel,
                       EF_GSUSB_MAX_CHANNELS - 1u);
    if (o->hw_timestamps < -1 || o->hw_timestamps > 1)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options: hw_timestamps %d (-1, 0 or 1)",
                       o->hw_timestamps);
    if (o->listen_only && o->loop_back)
        return ef_fail(m, EF_ERR_ARG,
                       "gs_usb options: listen-only and loop-back exclude "
                       "each other");
    if (o->timeout_ms > GSU_TIMEOUT_MAX_MS)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options: timeout %u ms (at most %u)",
                       (unsigned)o->timeout_ms, GSU_TIMEOUT_MAX_MS);
    g->opts = *o;
    return EF_OK;
}

int ef_gsusb_opts_parse(const char *s, ef_gsusb_opts_t *o, ef_msg_t *m)
{
    if (!s || !o)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options: NULL");
    char buf[128];
    if (strlen(s) >= sizeof buf)
        return ef_fail(m, EF_ERR_ARG, "gs_usb options '%.40s...': too long", s);
    snprintf(buf, sizeof buf, "%s", s);
    char *save = NULL;
    for (char *w = strtok_r(buf, ",", &save); w; w = strtok_r(NULL, ",", &save)) {
        if (!strcmp(w, "loopback") || !strcmp(w, "loop-back")) {
            o->loop_back = 1;
        } else if (!strcmp(w, "listen-only")) {
            o->listen_only = 1;
        } else if (!strcmp(w, "one-shot")) {
            o->one_shot = 1;
        } else if (!strcmp(w, "timestamps")) {
            o->hw_timestamps = 1;
        } else if (!strcmp(w, "no-timestamps")) {
            o->hw_timestamps = 0;
        } else if (!strncmp(w, "timeout=", 8)) {
            char *end;
            unsigned long t = strtoul(w + 8, &end, 10);
            if (!w[8] || *end || w[8] == '-' || t < 1 || t > GSU_TIMEOUT_MAX_MS)
                return ef_fail(m, EF_ERR_ARG, "gs_usb options: '%s': timeout=MS, 1..%u", w,
                               GSU_TIMEOUT_MAX_MS);
            o->timeout_ms = (uint32_t)t;
        } else if (!strncmp(w, "channel=", 8)) {
            char *end;
            unsigned long c = strtoul(w + 8, &end, 10);
            if (!w[8] || *end || c >= EF_GSUSB_MAX_CHANNELS)
                return ef_fail(m, EF_ERR_ARG, "gs_usb options: '%s': channel 0..%u", w,
                               EF_GSUSB_MAX_CHANNELS - 1u);
            o->channel = (uint8_t)c;
        } else {
            return ef_fail(m, EF_ERR_ARG,
                           "gs_usb options: unknown '%s' (loopback, listen-only, one-shot, "
                           "timestamps, no-timestamps, channel=N, timeout=MS)",
                           w);
        }
    }
    if (o->listen_only && o->loop_back)
        return ef_fail(m, EF_ERR_ARG,
                       "gs_usb options: listen-only and loopback exclude each "
                       "other");
    return EF_OK;
}

int ef_gsusb_spec_is(const char *s)
{
    return s && !strncmp(s, "gsusb", 5) && (s[5] == 0 || s[5] == ':' || s[5] == '@');
}

int ef_gsusb_spec_parse(const char *s, char *who, size_t who_n, uint32_t *bitrate, ef_msg_t *m)
{
    if (!s || !who || who_n == 0)
        return ef_fail(m, EF_ERR_ARG, "gs_usb spec: NULL");
    who[0] = 0;
    if (bitrate)
        *bitrate = 0;
    if (!ef_gsusb_spec_is(s))
        return ef_fail(m, EF_ERR_ARG, "'%s': not a gs_usb adapter (gsusb[:SERIAL][@BITRATE])", s);
    const char *p = s + 5;
    const char *at = strchr(p, '@');
    if (*p == ':') {
        size_t len = at ? (size_t)(at - p - 1) : strlen(p + 1);
        if (len == 0)
            return ef_fail(m, EF_ERR_ARG,
                           "'%s': empty serial after ':' (gsusb:SERIAL or gsusb:BUS-PORT)", s);
        if (len >= who_n)
            return ef_fail(m, EF_ERR_ARG, "'%s': serial longer than %zu characters", s, who_n - 1);
        for (size_t i = 0; i < len; i++)
            if (!isgraph((unsigned char)p[1 + i]))
                return ef_fail(m, EF_ERR_ARG,
                               "'%s': the serial has a space or control "
                               "character",
                               s);
        memcpy(who, p + 1, len);
        who[len] = 0;
    }
    if (at) {
        const char *v = at + 1;
        char *end;
        if (!isdigit((unsigned char)*v))
            return ef_fail(m, EF_ERR_ARG,
                           "'%s': bitrate after '@' must be a number of bit/s "
                           "(e.g. @500000)",
                           s);
        unsigned long long b = strtoull(v, &end, 10);
        if (*end == 'k' && end[1] == 0) { /* "@500k" reads naturally: accept it */
            b *= 1000u;
            end++;
        }
        if (*end)
            return ef_fail(m, EF_ERR_ARG,
                           "'%s': bitrate after '@' must be a number of bit/s "
                           "(e.g. @500000)",
                           s);
        if (b == 0 || b > 1000000u)
            return ef_fail(m, EF_ERR_ARG,
                           "'%s': bitrate %llu not 1..1000000 bit/s (classic "
                           "CAN)",
                           s, b);
        if (bitrate)
            *bitrate = (uint32_t)b;
    }
    return EF_OK;
}

const char *ef_gsusb_feature_str(uint32_t feature, char *buf, size_t n)
{
    static const struct {
        uint32_t bit;
        const char *name;
    } names[] = {
        {EF_GSUSB_FEAT_LISTEN_ONLY, "listen-only"},
        {EF_GSUSB_FEAT_LOOP_BACK, "loop-back"},
        {EF_GSUSB_FEAT_TRIPLE_SAMPLE, "triple-sample"},
        {EF_GSUSB_FEAT_ONE_SHOT, "one-shot"},
        {EF_GSUSB_FEAT_HW_TIMESTAMP, "timestamps"},
        {EF_GSUSB_FEAT_IDENTIFY, "identify"},
        {EF_GSUSB_FEAT_USER_ID, "user-id"},
        {EF_GSUSB_FEAT_PAD_PKTS, "pad-pkts"},
        {EF_GSUSB_FEAT_FD, "fd"},
        {EF_GSUSB_FEAT_BERR, "berr"},
        {EF_GSUSB_FEAT_GET_STATE, "get-state"},
    };
    size_t k = 0;
    if (!buf || n == 0)
        return "";
    buf[0] = 0;
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if ((feature & names[i].bit) && k < n)
            k += (size_t)snprintf(buf + k, n - k, "%s%s", k ? "," : "", names[i].name);
    if (!buf[0])
        snprintf(buf, n, "none");
    return buf;
}

/* ---- Control requests --------------------------------------------------------------- */

/* A libusb error of a control request as a code and a message naming the request. */
static int gsu_ctrl_error(const char *label, unsigned breq, int r, ef_msg_t *m)
{
    const char *req = ef_gsusb_req_name(breq);
    switch (r) {
    case LIBUSB_ERROR_TIMEOUT:
        return ef_fail(m, EF_ERR_TIMEOUT, "%s: %s: timed out (no answer within %d ms)", label, req,
                       EF_GSUSB_CTRL_TIMEOUT_MS);
    case LIBUSB_ERROR_PIPE:
        return ef_fail(m, EF_ERR_IO, "%s: %s: refused by the adapter (stall)", label, req);
    case LIBUSB_ERROR_OVERFLOW:
        return ef_fail(m, EF_ERR_PROTO, "%s: %s: oversized reply (more than asked for)", label,
                       req);
    case LIBUSB_ERROR_NO_DEVICE:
        return ef_fail(m, EF_ERR_IO, "%s: %s: adapter unplugged", label, req);
    default:
        return ef_fail(m, EF_ERR_IO, "%s: %s: %s", label, req, libusb_strerror(r));
    }
}

/* A synchronous vendor request; an IN reply of other than `len` bytes is a protocol error
 * (the decoders check again, this names the request). */
static int gsu_ctrl(libusb_device_handle *h, const char *label, int in, unsigned breq,
                    uint16_t wvalue, uint8_t *buf, uint16_t len, ef_msg_t *m)
{
    /* An IN request asks for more than the structure: a device limited to wLength could
     * never show that its reply is too long (a device of another protocol, a bug). */
    uint8_t big[GSU_CTRL_IN_MAX];
    int r = libusb_control_transfer(h, in ? EF_GSUSB_REQ_IN : EF_GSUSB_REQ_OUT, (uint8_t)breq,
                                    wvalue, GSU_IFACE, in ? big : buf,
                                    in ? (uint16_t)sizeof big : len, EF_GSUSB_CTRL_TIMEOUT_MS);
    if (r < 0)
        return gsu_ctrl_error(label, breq, r, m);
    if (r != len)
        return ef_fail(
            m, EF_ERR_PROTO, "%s: %s: %s of %d bytes, want %u", label, ef_gsusb_req_name(breq),
            in ? (r < len ? "short reply" : "oversized reply") : "short write", r, (unsigned)len);
    if (in)
        memcpy(buf, big, len);
    return EF_OK;
}

/* Prefix a decoder's message with the adapter's label. */
static int gsu_relabel(const char *label, int rc, ef_msg_t *m)
{
    if (rc != EF_OK && m) {
        char t[sizeof m->text];
        snprintf(t, sizeof t, "%s", m->text);
        ef_fail(m, rc, "%s: %s", label, t);
    }
    return rc;
}

static int gsu_read_devcfg(libusb_device_handle *h, const char *label, ef_gsusb_devcfg_t *dc,
                           ef_msg_t *m)
{
    uint8_t b[EF_GSUSB_DEVCFG_LEN];
    /* wValue 1 as the Linux driver sends it (the request is per device, not per channel). */
    int rc = gsu_ctrl(h, label, 1, EF_GSUSB_BREQ_DEVICE_CONFIG, 1, b, sizeof b, m);
    if (rc == EF_OK)
        rc = gsu_relabel(label, ef_gsusb_devcfg_decode(b, sizeof b, dc, m), m);
    return rc;
}

static int gsu_read_btconst(libusb_device_handle *h, const char *label, unsigned ch,
                            ef_gsusb_btconst_t *bc, ef_msg_t *m)
{
    uint8_t b[EF_GSUSB_BTCONST_LEN];
    int rc = gsu_ctrl(h, label, 1, EF_GSUSB_BREQ_BT_CONST, (uint16_t)ch, b, sizeof b, m);
    if (rc == EF_OK)
        rc = gsu_relabel(label, ef_gsusb_btconst_decode(b, sizeof b, bc, m), m);
    return rc;
}

/* ---- Latency figures ---------------------------------------------------------------- */

static void gsu_lat_add(ef_gsusb_lat_t *l, uint32_t us)
{
    if (l->n == 0 || us < l->min_us)
        l->min_us = us;
    if (us > l->max_us)
        l->max_us = us;
    l->n++;
    l->sum_us += us;
    unsigned k = 0;
    while (k + 1 < EF_GSUSB_LAT_BINS && (us >> (k + 1)) != 0)
        k++;
    l->hist[k]++;
}

double ef_gsusb_lat_mean(const ef_gsusb_lat_t *l)
{
    return l && l->n ? (double)l->sum_us / (double)l->n : 0.0;
}

void ef_gsusb_stats(const ef_gsusb_t *g, ef_gsusb_stats_t *st)
{
    if (g && st)
        *st = g->stats;
}

/* ---- Receive path (completions) ----------------------------------------------------- */

/* The adapter is gone: every op from now says so. */
static void gsu_gone(ef_gsusb_t *g)
{
    if (!g->gone)
        ef_fail(&g->msg, EF_ERR_BUS, "%s: adapter unplugged", g->label);
    g->gone = 1;
    g->seen |= EF_CANIF_DOWN;
    g->wake = 1;
}

/* The adapter broke its protocol (a frame that does not decode, a stalled or failing IN
 * endpoint): EF_CANIF_FAULT, so the master stops the drives under control through the
 * adapter, which may still send; the first fault's text is what `error` says. */
static void gsu_fault(ef_gsusb_t *g, const ef_msg_t *why)
{
    if (!(g->seen & EF_CANIF_FAULT))
        g->fault_msg = *why;
    g->msg = *why;
    g->seen |= EF_CANIF_FAULT;
    g->err_seen = 1; /* recv returns at once: the caller sees the condition promptly */
    g->wake = 1;
}

/* An error a completion met, for the next op to return (the first one wins). */
static void gsu_defer(ef_gsusb_t *g, int rc)
{
    if (!g->io_rc)
        g->io_rc = rc;
    g->wake = 1;
}

/* A device timestamp on the host clock: the offset is modular, so the device clock's wrap
 * needs nothing special. */
static uint32_t gsu_dev_to_host(const ef_gsusb_t *g, uint32_t dev_us)
{
    return dev_us + g->ts_offset;
}

/* SocketCAN-style error frame: the conditions it reports, as sc_error_frame does. */
static void gsu_error_frame(ef_gsusb_t *g, const ef_gsusb_frame_t *hf)
{
    g->err_frames++;
    g->err_seen = 1;
    g->wake = 1;
    if (hf->can_id & CAN_ERR_BUSOFF)
        g->seen |= EF_CANIF_BUS_OFF;
    if (hf->can_id & CAN_ERR_CRTL) {
        if (hf->data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))
            g->seen |= EF_CANIF_ERROR_PASSIVE;
        if (hf->data[1] & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING))
            g->seen |= EF_CANIF_ERROR_WARNING;
    }
    if (hf->can_id & CAN_ERR_RESTARTED) {
        g->seen |= EF_CANIF_RESTARTED;
        g->seen &= ~EF_CANIF_BUS_OFF;
    }
    if (hf->can_id & CAN_ERR_CNT) { /* counters in data[6], data[7] (SocketCAN's layout) */
        g->tec = hf->data[6];
        g->rec = hf->data[7];
    }
}

static void gsu_to_frame(const ef_gsusb_frame_t *hf, ef_can_frame_t *f)
{
    memset(f, 0, sizeof *f);
    if (hf->can_id & EF_GSUSB_ID_EFF) {
        f->id = hf->can_id & CAN_EFF_MASK;
        f->flags |= EF_CAN_FLAG_EFF;
    } else {
        f->id = hf->can_id & CAN_SFF_MASK;
    }
    f->dlc = hf->dlc;
    if (hf->can_id & EF_GSUSB_ID_RTR)
        f->flags |= EF_CAN_FLAG_RTR;
    else
        memcpy(f->data, hf->data, hf->dlc);
}

static int gsu_filter_pass(const ef_gsusb_t *g, const ef_gsusb_frame_t *hf)
{
    if (g->n_filters == 0)
        return 1;
    uint32_t id = hf->can_id & (EF_GSUSB_ID_EFF | EF_GSUSB_ID_RTR | CAN_EFF_MASK);
    for (int i = 0; i < g->n_filters; i++)
        if ((id & g->filters[i].mask) == (g->filters[i].id & g->filters[i].mask))
            return 1;
    return 0;
}

static void gsu_tx_slot_done(ef_gsusb_t *g, ef_gsusb_txs_t *s)
{
    if (!s->out_busy && !s->wait_echo && g->tx_inflight > 0)
        g->tx_inflight--;
}

/* An echo: the frame of slot echo_id is on the bus. */
static void gsu_echo(ef_gsusb_t *g, const ef_gsusb_frame_t *hf, uint32_t t_host)
{
    if (hf->echo_id >= EF_GSUSB_TX_WINDOW || !g->tx[hf->echo_id].wait_echo) {
        g->stats.unknown_echo++;
        ef_fail(&g->msg, EF_ERR_PROTO,
                "%s: protocol error: echo of frame %u, which is not in flight (%u such echoes)",
                g->label, (unsigned)hf->echo_id, (unsigned)g->stats.unknown_echo);
        return;
    }
    ef_gsusb_txs_t *s = &g->tx[hf->echo_id];
    s->wait_echo = 0;
    gsu_lat_add(&g->stats.echo, t_host - s->t_submit);
    if (hf->has_ts && g->ts_synced) {
        int32_t d = (int32_t)(gsu_dev_to_host(g, hf->ts_us) - s->t_submit);
        gsu_lat_add(&g->stats.echo_dev, d > 0 ? (uint32_t)d : 0u);
    }
    g->n_tx++;
    g->tx_bits += ef_can_frame_bits(&s->f);
    g->seen &= ~EF_CANIF_DOWN;
    if (g->log)
        ef_sockcan_log_frame(g->log, g->log_if, &s->f);
    gsu_tx_slot_done(g, s);
    g->wake = 1;
}

/* One IN transfer's bytes: an echo, an error frame or a received frame. */
static void gsu_in_frame(ef_gsusb_t *g, const uint8_t *buf, size_t n)
{
    ef_gsusb_frame_t hf;
    ef_msg_t dm;
    uint32_t now = gsu_now();
    g->stats.in_xfers++;
    int rc = ef_gsusb_frame_decode(buf, n, g->with_ts, g->pad_to, g->devcfg.channels, &hf, &dm);
    if (rc != EF_OK) {
        /* Dropped, never handed on; and the adapter is no longer to be trusted: the master
         * stops the drives (EF_CANIF_FAULT) while frames can still go out. */
        g->stats.bad_frames++;
        ef_msg_t why;
        ef_fail(&why, EF_ERR_IO, "%s: bad frame from the adapter: %s", g->label, dm.text);
        gsu_fault(g, &why);
        return;
    }
    if (hf.channel != g->opts.channel) {
        g->stats.other_channel++;
        return;
    }
    if (hf.flags & EF_GSUSB_FLAG_OVERFLOW) {
        g->stats.overflow++;
        g->rx_overrun++; /* the device lost at least one frame before this one */
    }
    if (hf.echo_id != EF_GSUSB_ECHO_RX) {
        gsu_echo(g, &hf, now);
        return;
    }
    if (hf.can_id & EF_GSUSB_ID_ERR) {
        if (g->log)
            /* Error frames have no ef_can_frame_t form: the raw SocketCAN id. */
            ef_sockcan_log_raw(g->log, g->log_if, hf.can_id & (CAN_ERR_MASK | CAN_ERR_FLAG), hf.dlc,
                               hf.data);
        gsu_error_frame(g, &hf);
        return;
    }
    if (!gsu_filter_pass(g, &hf))
        return;
    ef_gsusb_rxe_t e;
    gsu_to_frame(&hf, &e.f);
    e.ts = hf.has_ts && g->ts_synced ? gsu_dev_to_host(g, hf.ts_us) : now;
    if (g->log)
        ef_sockcan_log_frame(g->log, g->log_if, &e.f);
    if (g->ring_count >= EF_GSUSB_RX_RING) {
        g->stats.ring_full++;
        g->rx_overrun++;
        return;
    }
    g->ring[(g->ring_head + g->ring_count) % EF_GSUSB_RX_RING] = e;
    g->ring_count++;
    g->seen &= ~EF_CANIF_DOWN;
    g->wake = 1;
}

static void LIBUSB_CALL gsu_rx_cb(struct libusb_transfer *x)
{
    ef_gsusb_t *g = x->user_data;
    switch (x->status) {
    case LIBUSB_TRANSFER_COMPLETED:
        g->in_errors = 0;
        gsu_in_frame(g, x->buffer, (size_t)x->actual_length);
        break;
    case LIBUSB_TRANSFER_CANCELLED:
        g->rx_active--;
        return;
    case LIBUSB_TRANSFER_NO_DEVICE:
        g->rx_active--;
        gsu_gone(g);
        return;
    case LIBUSB_TRANSFER_STALL: { /* the adapter's own statement: it will not send */
        g->rx_active--;
        g->stats.xfer_errors++;
        ef_msg_t why;
        ef_fail(&why, EF_ERR_IO,
                "%s: bulk IN endpoint 0x%02x stalled (the adapter stopped sending)", g->label,
                (unsigned)x->endpoint);
        gsu_fault(g, &why);
        return;
    }
    default: { /* error, overflow: may be the first sign of an unplug; a run is fatal */
        g->stats.xfer_errors++;
        uint32_t now = gsu_now();
        if (g->in_errors++ == 0)
            g->in_err_t0 = now;
        if (g->in_errors >= GSU_IN_ERRORS_MAX &&
            (uint32_t)(now - g->in_err_t0) >= GSU_IN_ERROR_US) {
            g->rx_active--;
            ef_msg_t why;
            ef_fail(&why, EF_ERR_IO, "%s: bulk IN: %s, %d times in a row over %u ms", g->label,
                    libusb_error_name((int)x->status), g->in_errors,
                    (unsigned)((uint32_t)(now - g->in_err_t0) / 1000u));
            gsu_fault(g, &why);
            return;
        }
        break;
    }
    }
    if (g->gone || !g->is_open) {
        g->rx_active--;
        return;
    }
    int r = libusb_submit_transfer(x);
    if (r != 0) {
        g->rx_active--;
        if (r == LIBUSB_ERROR_NO_DEVICE) {
            gsu_gone(g);
        } else {
            ef_fail(&g->msg, EF_ERR_IO, "%s: bulk IN resubmit: %s", g->label, libusb_strerror(r));
            gsu_defer(g, EF_ERR_IO);
        }
    }
}

static void LIBUSB_CALL gsu_tx_cb(struct libusb_transfer *x)
{
    ef_gsusb_t *g = x->user_data;
    ef_gsusb_txs_t *s = NULL;
    for (int i = 0; i < EF_GSUSB_TX_WINDOW && !s; i++)
        if (g->tx[i].xfer == x)
            s = &g->tx[i];
    if (!s)
        return;
    s->out_busy = 0;
    g->stats.out_xfers++;
    g->wake = 1;
    if (x->status != LIBUSB_TRANSFER_COMPLETED) {
        /* The frame never reached the adapter: no echo will come for it. */
        s->wait_echo = 0;
        if (x->status == LIBUSB_TRANSFER_NO_DEVICE) {
            gsu_gone(g);
        } else if (x->status != LIBUSB_TRANSFER_CANCELLED) {
            g->stats.xfer_errors++;
            ef_fail(&g->msg, EF_ERR_IO, "%s: bulk OUT: %s", g->label,
                    libusb_error_name((int)x->status));
            gsu_defer(g, EF_ERR_IO);
        }
    }
    gsu_tx_slot_done(g, s);
}

/* GET_STATE and TIMESTAMP answers. */
static void LIBUSB_CALL gsu_ctl_cb(struct libusb_transfer *x)
{
    ef_gsusb_t *g = x->user_data;
    ef_gsusb_ctl_t *c = x == g->ctl[0].xfer ? &g->ctl[0] : &g->ctl[1];
    const uint8_t *data = libusb_control_transfer_get_data(x);
    c->busy = 0;
    if (x->status == LIBUSB_TRANSFER_NO_DEVICE) {
        gsu_gone(g);
        return;
    }
    if (x->status != LIBUSB_TRANSFER_COMPLETED)
        return; /* a poll that fails is retried at the next period; the data path decides */
    ef_msg_t dm;
    if (c == &g->ctl[0]) {
        ef_gsusb_state_t st;
        if (ef_gsusb_state_decode(data, (size_t)x->actual_length, &st, &dm) != EF_OK) {
            ef_fail(&g->msg, EF_ERR_PROTO, "%s: %s", g->label, dm.text);
            return;
        }
        g->stats.state_polls++;
        g->dev_state = (int)st.state;
        g->tec = (int16_t)(st.txerr > 32767u ? 32767 : st.txerr);
        g->rec = (int16_t)(st.rxerr > 32767u ? 32767 : st.rxerr);
        if (st.state == EF_GSUSB_STATE_BUS_OFF)
            g->seen |= EF_CANIF_BUS_OFF;
        else if (st.state == EF_GSUSB_STATE_PASSIVE)
            g->seen |= EF_CANIF_ERROR_PASSIVE;
        else if (st.state == EF_GSUSB_STATE_WARNING)
            g->seen |= EF_CANIF_ERROR_WARNING;
    } else {
        uint32_t dev;
        if (ef_gsusb_u32_decode(data, (size_t)x->actual_length, "TIMESTAMP", &dev, &dm) != EF_OK) {
            ef_fail(&g->msg, EF_ERR_PROTO, "%s: %s", g->label, dm.text);
            return;
        }
        /* The device read its clock somewhere between submission and completion. */
        uint32_t now = gsu_now();
        uint32_t mid = c->t_submit + (now - c->t_submit) / 2u;
        g->ts_offset = mid - dev;
        g->ts_synced = 1;
    }
}

/* Start the periodic polls that are due (never blocks: asynchronous control requests). */
static void gsu_housekeeping(ef_gsusb_t *g)
{
    uint32_t now = gsu_now();
    if (g->gone || now - g->poll_last < EF_GSUSB_POLL_MS * 1000u)
        return;
    g->poll_last = now;
    for (int i = 0; i < 2; i++) {
        ef_gsusb_ctl_t *c = &g->ctl[i];
        unsigned breq = i == 0 ? EF_GSUSB_BREQ_GET_STATE : EF_GSUSB_BREQ_TIMESTAMP;
        uint16_t len = i == 0 ? EF_GSUSB_STATE_LEN : EF_GSUSB_U32_LEN;
        if (!c->xfer || c->busy)
            continue;
        libusb_fill_control_setup(c->buf, EF_GSUSB_REQ_IN, (uint8_t)breq, g->opts.channel,
                                  GSU_IFACE, len);
        libusb_fill_control_transfer(c->xfer, g->h, c->buf, gsu_ctl_cb, g,
                                     EF_GSUSB_CTRL_TIMEOUT_MS);
        c->t_submit = gsu_now();
        if (libusb_submit_transfer(c->xfer) == 0)
            c->busy = 1;
    }
}

/* Run libusb's events for up to timeout_us (0: only what is ready). */
static void gsu_events(ef_gsusb_t *g, uint32_t timeout_us)
{
    struct timeval tv = {.tv_sec = (time_t)(timeout_us / 1000000u),
                         .tv_usec = (suseconds_t)(timeout_us % 1000000u)};
    g->wake = 0;
    int r = libusb_handle_events_timeout_completed(g->usb, &tv, &g->wake);
    if (r == LIBUSB_ERROR_NO_DEVICE)
        gsu_gone(g);
}

/* ---- Transmit ----------------------------------------------------------------------- */

static int gsu_free_slot(const ef_gsusb_t *g)
{
    for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++)
        if (!g->tx[i].out_busy && !g->tx[i].wait_echo)
            return i;
    return -1;
}

/* Submit f in a free slot: EF_OK, EF_ERR_FULL (no slot), EF_ERR_BUS or EF_ERR_IO. */
static int gsu_submit(ef_gsusb_t *g, const ef_can_frame_t *f)
{
    int i = gsu_free_slot(g);
    if (i < 0)
        return EF_ERR_FULL;
    ef_gsusb_txs_t *s = &g->tx[i];
    ef_gsusb_frame_t hf;
    memset(&hf, 0, sizeof hf);
    hf.echo_id = (uint32_t)i;
    if (f->flags & EF_CAN_FLAG_EFF)
        hf.can_id = (f->id & CAN_EFF_MASK) | EF_GSUSB_ID_EFF;
    else
        hf.can_id = f->id & CAN_SFF_MASK;
    if (f->flags & EF_CAN_FLAG_RTR)
        hf.can_id |= EF_GSUSB_ID_RTR;
    else
        memcpy(hf.data, f->data, f->dlc);
    hf.dlc = f->dlc;
    hf.channel = g->opts.channel;
    size_t n = ef_gsusb_frame_encode(&hf, s->buf); /* host frames out carry no timestamp */
    libusb_fill_bulk_transfer(s->xfer, g->h, g->ep_out, s->buf, (int)n, gsu_tx_cb, g,
                              gsu_out_ms(g));
    s->f = *f;
    s->t_submit = gsu_now();
    int r = libusb_submit_transfer(s->xfer);
    if (r == LIBUSB_ERROR_NO_DEVICE) {
        gsu_gone(g);
        return EF_ERR_BUS;
    }
    if (r != 0)
        return ef_fail(&g->msg, EF_ERR_IO, "%s: bulk OUT submit: %s", g->label, libusb_strerror(r));
    s->out_busy = 1;
    s->wait_echo = 1;
    g->tx_inflight++;
    if (g->tx_inflight > g->stats.max_in_flight)
        g->stats.max_in_flight = g->tx_inflight;
    return EF_OK;
}

/* Move held frames into free slots, oldest first. */
static int gsu_drain_backlog(ef_gsusb_t *g)
{
    while (g->bl_count > 0) {
        int rc = gsu_submit(g, &g->backlog[g->bl_head]);
        if (rc == EF_ERR_FULL)
            return EF_OK;
        if (rc != EF_OK)
            return rc;
        g->bl_head = (g->bl_head + 1u) % EF_GSUSB_BACKLOG;
        g->bl_count--;
    }
    return EF_OK;
}

/* What every op checks first: gone, or an error a completion left. */
static int gsu_pending_error(ef_gsusb_t *g)
{
    if (g->gone) {
        ef_fail(&g->msg, EF_ERR_BUS, "%s: adapter unplugged", g->label);
        return EF_ERR_BUS;
    }
    if (g->io_rc)
        return g->io_rc; /* sticky: g->msg says what it was */
    uint32_t now = gsu_now();
    for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++) {
        const ef_gsusb_txs_t *s = &g->tx[i];
        if (s->wait_echo && now - s->t_submit > gsu_echo_ms(g) * 1000u) {
            /* A frame never confirmed is one the bus never carried: nothing sent after it
             * can be trusted to arrive either (no ACK on the bus, or the firmware hung). */
            ef_fail(&g->msg, EF_ERR_IO,
                    "%s: frame %03X not confirmed by the adapter (no echo) within %d ms: no "
                    "other node acknowledging on the bus, or the adapter hung",
                    g->label, (unsigned)s->f.id, (int)gsu_echo_ms(g));
            g->io_rc = EF_ERR_IO;
            return g->io_rc;
        }
    }
    return EF_OK;
}

static int gsu_flush(void *ctx)
{
    ef_gsusb_t *g = ctx;
    if (!g || !g->is_open)
        return EF_ERR_ARG;
    gsu_events(g, 0);
    int rc = gsu_pending_error(g);
    if (rc != EF_OK)
        return rc;
    return gsu_drain_backlog(g);
}

static int gsu_send(void *ctx, const ef_can_frame_t *f)
{
    ef_gsusb_t *g = ctx;
    if (!g || !f || !g->is_open)
        return EF_ERR_ARG;
    if (f->dlc > EF_CAN_MAX_DLC)
        return ef_fail(&g->msg, EF_ERR_ARG, "%s: send: dlc %u > 8", g->label, f->dlc);
    if (g->opts.listen_only)
        return ef_fail(&g->msg, EF_ERR_IO, "%s: send: the channel is listen-only", g->label);
    int rc = gsu_flush(g); /* completions first: echoes free slots, unplug is seen */
    if (rc != EF_OK)
        return rc;
    if (g->seen & EF_CANIF_BUS_OFF)
        return ef_fail(&g->msg, EF_ERR_BUS, "%s: send: controller is bus-off", g->label);
    if (g->bl_count == 0) {
        rc = gsu_submit(g, f);
        if (rc != EF_ERR_FULL)
            return rc;
        g->tx_full++;
    }
    if (g->bl_count >= EF_GSUSB_BACKLOG)
        return ef_fail(&g->msg, EF_ERR_AGAIN, "%s: send: %d frames unconfirmed and backlog full",
                       g->label, EF_GSUSB_TX_WINDOW);
    g->backlog[(g->bl_head + g->bl_count) % EF_GSUSB_BACKLOG] = *f;
    g->bl_count++;
    g->stats.held++;
    return EF_OK;
}

static int gsu_recv(void *ctx, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us)
{
    ef_gsusb_t *g = ctx;
    if (!g || !f || !g->is_open)
        return EF_ERR_ARG;
    uint32_t t0 = gsu_now();
    g->err_seen = 0;
    for (int first = 1;; first = 0) {
        if (g->ring_count > 0) {
            ef_gsusb_rxe_t *e = &g->ring[g->ring_head];
            *f = e->f;
            if (ts_us)
                *ts_us = e->ts;
            g->ring_head = (g->ring_head + 1u) % EF_GSUSB_RX_RING;
            g->ring_count--;
            g->n_rx++;
            return EF_OK;
        }
        int rc = gsu_pending_error(g);
        if (rc != EF_OK)
            return rc;
        if (g->err_seen)
            return EF_ERR_AGAIN;
        uint32_t spent = gsu_now() - t0;
        if (!first && spent >= timeout_us)
            return EF_ERR_AGAIN;
        gsu_events(g, first ? 0u : timeout_us - spent);
        gsu_housekeeping(g);
        /* Echoes freed slots: held frames go now, not at the caller's next flush. */
        rc = gsu_drain_backlog(g);
        if (rc == EF_ERR_IO)
            gsu_defer(g, rc);
    }
}

static void gsu_status(void *ctx, uint32_t clear, ef_canif_status_t *st)
{
    ef_gsusb_t *g = ctx;
    memset(st, 0, sizeof *st);
    if (!g->is_open)
        st->state = EF_CANIF_STATE_STOPPED;
    else if (g->gone)
        st->state = EF_CANIF_STATE_DOWN;
    else if (g->dev_state >= EF_GSUSB_STATE_ACTIVE && g->dev_state <= EF_GSUSB_STATE_BUS_OFF &&
             !(g->seen & EF_CANIF_BUS_OFF))
        st->state = (ef_canif_state_t)(EF_CANIF_STATE_ACTIVE + g->dev_state);
    else
        st->state = ef_canif_state_of(g->seen);
    st->seen = g->seen;
    st->err_frames = g->err_frames;
    st->tx_pending = g->bl_count;
    st->tx_unconfirmed = g->tx_inflight;
    st->tx_full = g->tx_full;
    st->rx_overrun = g->rx_overrun;
    st->tec = g->tec;
    st->rec = g->rec;
    st->tx = g->n_tx;
    st->rx = g->n_rx;
    st->tx_bits = g->tx_bits;
    g->seen &= ~clear;
}

/* The last failure; the adapter's first protocol fault while it is still there (what the
 * stream's final message names, whatever sends failed after it). */
static const char *gsu_error(void *ctx)
{
    const ef_gsusb_t *g = ctx;
    return g->fault_msg.text[0] && !g->gone ? g->fault_msg.text : g->msg.text;
}

static uint32_t gsu_now_us(void *ctx)
{
    (void)ctx;
    return gsu_now();
}

/* ---- Open and close ----------------------------------------------------------------- */

/* Cancel what is in flight and wait (bounded) for the completions: a transfer is freed
 * only once libusb has handed it back. */
static void gsu_cancel_all(ef_gsusb_t *g)
{
    for (int i = 0; i < EF_GSUSB_RX_XFERS; i++)
        if (g->rx[i])
            (void)libusb_cancel_transfer(g->rx[i]);
    for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++)
        if (g->tx[i].xfer && g->tx[i].out_busy)
            (void)libusb_cancel_transfer(g->tx[i].xfer);
    for (int i = 0; i < 2; i++)
        if (g->ctl[i].xfer && g->ctl[i].busy)
            (void)libusb_cancel_transfer(g->ctl[i].xfer);
    uint32_t t0 = gsu_now();
    for (;;) {
        int busy = g->rx_active > 0;
        for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++)
            busy |= g->tx[i].out_busy;
        busy |= g->ctl[0].busy | g->ctl[1].busy;
        if (!busy || gsu_now() - t0 > GSU_CLOSE_WAIT_MS * 1000u)
            break;
        struct timeval tv = {0, 50000};
        (void)libusb_handle_events_timeout_completed(g->usb, &tv, NULL);
    }
}

static void gsu_free_xfers(ef_gsusb_t *g)
{
    /* A transfer libusb still holds (it did not complete within the wait) is leaked on
     * purpose: freeing it would let its completion write into freed memory. */
    for (int i = 0; i < EF_GSUSB_RX_XFERS; i++) {
        if (g->rx[i] && g->rx_active <= 0) {
            free(g->rx[i]->buffer);
            libusb_free_transfer(g->rx[i]);
        }
        g->rx[i] = NULL;
    }
    for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++) {
        if (g->tx[i].xfer && !g->tx[i].out_busy)
            libusb_free_transfer(g->tx[i].xfer);
        g->tx[i].xfer = NULL;
    }
    for (int i = 0; i < 2; i++) {
        if (g->ctl[i].xfer && !g->ctl[i].busy)
            libusb_free_transfer(g->ctl[i].xfer);
        g->ctl[i].xfer = NULL;
    }
}

static void gsu_close(void *ctx)
{
    ef_gsusb_t *g = ctx;
    if (!g)
        return;
    if (g->h) {
        g->is_open = 0; /* completions from here on do not resubmit */
        gsu_cancel_all(g);
        if (g->claimed && !g->gone) { /* stop the channel: the adapter leaves the bus */
            uint8_t b[EF_GSUSB_MODE_LEN];
            ef_gsusb_mode_encode(EF_GSUSB_MODE_RESET, 0, b);
            (void)libusb_control_transfer(g->h, EF_GSUSB_REQ_OUT, EF_GSUSB_BREQ_MODE,
                                          g->opts.channel, GSU_IFACE, b, sizeof b,
                                          EF_GSUSB_CTRL_TIMEOUT_MS);
        }
        gsu_free_xfers(g);
        if (g->claimed)
            (void)libusb_release_interface(g->h, GSU_IFACE);
        if (g->reattach && !g->gone)
            (void)libusb_attach_kernel_driver(g->h, GSU_IFACE);
        libusb_close(g->h);
    }
    if (g->usb)
        libusb_exit(g->usb);
    if (g->log)
        fclose(g->log);
    /* Keep the options, the figures and the last message (read after close); reset the
     * rest. */
    ef_gsusb_opts_t o = g->opts;
    ef_gsusb_stats_t s = g->stats;
    ef_msg_t msg = g->msg, fault = g->fault_msg;
    char label[sizeof g->label];
    memcpy(label, g->label, sizeof label);
    ef_gsusb_init(g);
    g->opts = o;
    g->stats = s;
    g->msg = msg;
    g->fault_msg = fault;
    memcpy(g->label, label, sizeof label);
}

/* libusb's context, with a clear message where it cannot start. */
static int gsu_usb_init(libusb_context **ctx, ef_msg_t *m)
{
    int r = libusb_init(ctx);
    if (r != 0) {
        *ctx = NULL;
        return ef_fail(m, EF_ERR_IO,
                       "gs_usb: libusb_init: %s (no USB support here: /dev/bus/usb and sysfs "
                       "needed)",
                       libusb_strerror(r));
    }
    return EF_OK;
}

/* Find the adapter `who` names ("": the only one); opens it into *h. */
static int gsu_find(ef_gsusb_t *g, const char *who, ef_msg_t *m)
{
    libusb_device **list;
    ssize_t n = libusb_get_device_list(g->usb, &list);
    if (n < 0)
        return ef_fail(m, EF_ERR_IO, "gs_usb: listing USB devices: %s", libusb_strerror((int)n));
    int by_path = gsu_is_path(who), count = 0, denied = 0, denied_match = 0;
    char seen[256] = "";
    libusb_device_handle *ph = NULL;
    for (ssize_t i = 0; i < n; i++) {
        struct libusb_device_descriptor dd;
        if (libusb_get_device_descriptor(list[i], &dd) != 0 ||
            !gsu_id_known(dd.idVendor, dd.idProduct))
            continue;
        char path[32], serial[64] = "";
        gsu_path(list[i], path, sizeof path);
        libusb_device_handle *h = NULL;
        int r = libusb_open(list[i], &h);
        if (r == 0)
            gsu_string(h, dd.iSerialNumber, serial, sizeof serial);
        else if (r == LIBUSB_ERROR_ACCESS)
            denied++;
        size_t k = strlen(seen);
        if (k + 2 < sizeof seen)
            snprintf(seen + k, sizeof seen - k, "%s%s%s%s%s", k ? ", " : "", path,
                     serial[0] ? " (serial " : "", serial, serial[0] ? ")" : "");
        /* An adapter that cannot be opened matches by path or as the only one. */
        int match = !who[0] || (by_path ? !strcmp(path, who) : h && !strcmp(serial, who));
        if (match) {
            count++;
            if (!ph && h) {
                ph = h;
                h = NULL;
                snprintf(g->path, sizeof g->path, "%s", path);
                snprintf(g->serial, sizeof g->serial, "%s", serial);
            } else if (!ph && r == LIBUSB_ERROR_ACCESS && !denied_match) {
                denied_match = 1;
                snprintf(g->path, sizeof g->path, "%s", path);
            }
        }
        if (h)
            libusb_close(h);
    }
    libusb_free_device_list(list, 1);
    if (!who[0] && count > 1) {
        if (ph)
            libusb_close(ph);
        return ef_fail(m, EF_ERR_IO,
                       "gs_usb: %d adapters found (%s): name one, gsusb:SERIAL or gsusb:BUS-PORT",
                       count, seen);
    }
    if (!ph) {
        if (denied_match)
            return ef_fail(m, EF_ERR_IO, "gs_usb %s: %s", g->path, gsu_access_hint);
        if (!seen[0])
            return ef_fail(m, EF_ERR_IO,
                           "gs_usb%s%s: no gs_usb adapter found (USB ids 1d50:606f, 1209:2323, "
                           "1cd2:606f, 16d0:10b8)",
                           who[0] ? " " : "", who);
        return ef_fail(m, EF_ERR_IO, "gs_usb %s: no such adapter (found: %s%s)", who, seen,
                       denied ? "; some could not be opened to read their serial: permissions"
                              : "");
    }
    g->h = ph;
    return EF_OK;
}

/* The first bulk IN and OUT endpoints of interface 0, alternate setting 0. */
static int gsu_endpoints(ef_gsusb_t *g, ef_msg_t *m)
{
    struct libusb_config_descriptor *cd;
    int r = libusb_get_active_config_descriptor(libusb_get_device(g->h), &cd);
    if (r != 0)
        return ef_fail(m, EF_ERR_IO, "%s: configuration descriptor: %s", g->label,
                       libusb_strerror(r));
    g->ep_in = g->ep_out = 0;
    if (cd->bNumInterfaces > GSU_IFACE && cd->interface[GSU_IFACE].num_altsetting > 0) {
        const struct libusb_interface_descriptor *id = &cd->interface[GSU_IFACE].altsetting[0];
        for (int i = 0; i < id->bNumEndpoints; i++) {
            const struct libusb_endpoint_descriptor *e = &id->endpoint[i];
            if ((e->bmAttributes & LIBUSB_TRANSFER_TYPE_MASK) != LIBUSB_TRANSFER_TYPE_BULK)
                continue;
            if ((e->bEndpointAddress & LIBUSB_ENDPOINT_IN) && !g->ep_in) {
                g->ep_in = e->bEndpointAddress;
                g->mps_in = e->wMaxPacketSize;
            } else if (!(e->bEndpointAddress & LIBUSB_ENDPOINT_IN) && !g->ep_out) {
                g->ep_out = e->bEndpointAddress;
            }
        }
    }
    libusb_free_config_descriptor(cd);
    if (!g->ep_in || !g->ep_out || g->mps_in == 0)
        return ef_fail(m, EF_ERR_PROTO, "%s: interface 0 lacks a bulk IN or OUT endpoint",
                       g->label);
    return EF_OK;
}

/* Detach the kernel driver (remembered for close) and claim interface 0. */
static int gsu_claim(ef_gsusb_t *g, ef_msg_t *m)
{
    int r = libusb_kernel_driver_active(g->h, GSU_IFACE);
    if (r == 1) {
        r = libusb_detach_kernel_driver(g->h, GSU_IFACE);
        if (r != 0 && r != LIBUSB_ERROR_NOT_FOUND)
            return ef_fail(m, EF_ERR_IO, "%s: detaching the kernel driver: %s%s", g->label,
                           libusb_strerror(r), r == LIBUSB_ERROR_ACCESS ? " (permissions)" : "");
        g->reattach = r == 0;
    }
    r = libusb_claim_interface(g->h, GSU_IFACE);
    if (r == LIBUSB_ERROR_BUSY)
        return ef_fail(m, EF_ERR_IO, "%s: already claimed by another program", g->label);
    if (r == LIBUSB_ERROR_ACCESS)
        return ef_fail(m, EF_ERR_IO, "%s: %s", g->label, gsu_access_hint);
    if (r != 0)
        return ef_fail(m, EF_ERR_IO, "%s: claiming interface 0: %s", g->label, libusb_strerror(r));
    g->claimed = 1;
    return EF_OK;
}

/* The options asked for against what BT_CONST offers; the MODE flags. */
static int gsu_mode_flags(ef_gsusb_t *g, ef_msg_t *m)
{
    static const struct {
        size_t off;
        uint32_t feat, mode;
        const char *name;
    } opt[] = {
        {offsetof(ef_gsusb_opts_t, loop_back), EF_GSUSB_FEAT_LOOP_BACK, EF_GSUSB_MODE_LOOP_BACK,
         "loop-back"},
        {offsetof(ef_gsusb_opts_t, listen_only), EF_GSUSB_FEAT_LISTEN_ONLY,
         EF_GSUSB_MODE_LISTEN_ONLY, "listen-only"},
        {offsetof(ef_gsusb_opts_t, one_shot), EF_GSUSB_FEAT_ONE_SHOT, EF_GSUSB_MODE_ONE_SHOT,
         "one-shot"},
    };
    uint32_t feat = g->btc.feature, flags = EF_GSUSB_MODE_NORMAL;
    char fs[160];
    for (size_t i = 0; i < sizeof opt / sizeof opt[0]; i++) {
        if (!((const uint8_t *)&g->opts)[opt[i].off])
            continue;
        if (!(feat & opt[i].feat))
            return ef_fail(m, EF_ERR_IO, "%s: the adapter does not offer %s (it offers: %s)",
                           g->label, opt[i].name, ef_gsusb_feature_str(feat, fs, sizeof fs));
        flags |= opt[i].mode;
    }
    if (g->opts.hw_timestamps == 1 && !(feat & EF_GSUSB_FEAT_HW_TIMESTAMP))
        return ef_fail(m, EF_ERR_IO,
                       "%s: the adapter does not offer hardware timestamps (it offers: %s)",
                       g->label, ef_gsusb_feature_str(feat, fs, sizeof fs));
    g->with_ts = g->opts.hw_timestamps != 0 && (feat & EF_GSUSB_FEAT_HW_TIMESTAMP);
    if (g->with_ts)
        flags |= EF_GSUSB_MODE_HW_TIMESTAMP;
    if (feat & EF_GSUSB_FEAT_BERR)
        flags |= EF_GSUSB_MODE_BERR;
    /* Padding is the device's choice where it offers it: accept padded transfers. */
    g->pad_to = (feat & EF_GSUSB_FEAT_PAD_PKTS) ? g->mps_in : 0;
    g->mode_flags = flags;
    return EF_OK;
}

/* The configuration requests, in the Linux driver's order. */
static int gsu_configure(ef_gsusb_t *g, uint32_t bitrate, ef_msg_t *m)
{
    uint8_t b[EF_GSUSB_BTCONST_LEN];
    const char *L = g->label;
    ef_gsusb_put32(b, EF_GSUSB_HOST_FORMAT_LE);
    int rc = gsu_ctrl(g->h, L, 0, EF_GSUSB_BREQ_HOST_FORMAT, 1, b, EF_GSUSB_U32_LEN, m);
    if (rc == EF_OK)
        rc = gsu_read_devcfg(g->h, L, &g->devcfg, m);
    if (rc != EF_OK)
        return rc;
    if (g->opts.channel >= g->devcfg.channels)
        return ef_fail(m, EF_ERR_ARG, "%s: channel %u: the adapter has %u channel%s", L,
                       (unsigned)g->opts.channel, (unsigned)g->devcfg.channels,
                       g->devcfg.channels == 1 ? "" : "s");
    uint16_t ch = g->opts.channel;
    if ((rc = gsu_read_btconst(g->h, L, ch, &g->btc, m)) != EF_OK)
        return rc;
    if ((rc = gsu_mode_flags(g, m)) != EF_OK)
        return rc;
    ef_msg_t cm;
    uint32_t actual = 0;
    rc = ef_gsusb_bittiming_calc(&g->btc, bitrate, &g->timing, &actual, &g->sp_permille, &cm);
    if (rc != EF_OK)
        return ef_fail(m, rc == EF_ERR_ARG ? EF_ERR_ARG : EF_ERR_IO, "%s: %s", L, cm.text);
    g->bitrate = actual;
    ef_gsusb_bittiming_encode(&g->timing, b);
    if ((rc = gsu_ctrl(g->h, L, 0, EF_GSUSB_BREQ_BITTIMING, ch, b, EF_GSUSB_BITTIME_LEN, m)))
        return rc;
    if (g->with_ts) {
        uint32_t t0 = gsu_now(), dev;
        if ((rc = gsu_ctrl(g->h, L, 1, EF_GSUSB_BREQ_TIMESTAMP, ch, b, EF_GSUSB_U32_LEN, m)))
            return rc;
        uint32_t t1 = gsu_now();
        if ((rc = gsu_relabel(L, ef_gsusb_u32_decode(b, 4, "TIMESTAMP", &dev, m), m)))
            return rc;
        g->ts_offset = t0 + (t1 - t0) / 2u - dev;
        g->ts_synced = 1;
    }
    if (g->btc.feature & EF_GSUSB_FEAT_BERR) {
        ef_gsusb_put32(b, 1);
        if ((rc = gsu_ctrl(g->h, L, 0, EF_GSUSB_BREQ_BERR, ch, b, EF_GSUSB_U32_LEN, m)))
            return rc;
    }
    ef_gsusb_mode_encode(EF_GSUSB_MODE_START, g->mode_flags, b);
    rc = gsu_ctrl(g->h, L, 0, EF_GSUSB_BREQ_MODE, ch, b, EF_GSUSB_MODE_LEN, m);
    if (rc != EF_OK && m && strstr(m->text, "(stall)")) {
        /* An adapter can only take BITTIMING's data and refuse it afterwards: the stall of
         * the MODE start that follows is then its verdict on the timing. */
        char t[200];
        snprintf(t, sizeof t, "%.199s", m->text);
        ef_fail(m, rc,
                "%s; the BITTIMING before it (brp %u, %u+%u+%u quanta: %u bit/s, sample "
                "point %.1f %%) may have been refused",
                t, (unsigned)g->timing.brp, (unsigned)(g->timing.prop_seg + 1u),
                (unsigned)g->timing.phase_seg1, (unsigned)g->timing.phase_seg2,
                (unsigned)g->bitrate, g->sp_permille / 10.0);
    }
    return rc;
}

/* Allocate the transfers and start receiving. */
static int gsu_start_io(ef_gsusb_t *g, ef_msg_t *m)
{
    int len = g->mps_in;
    while (len < (int)EF_GSUSB_FRAME_TS_LEN) /* a frame may span packets of a small endpoint */
        len += g->mps_in;
    for (int i = 0; i < EF_GSUSB_TX_WINDOW; i++)
        if (!(g->tx[i].xfer = libusb_alloc_transfer(0)))
            return ef_fail(m, EF_ERR_NOMEM, "%s: no memory for transfers", g->label);
    for (int i = 0; i < 2; i++)
        if (!(g->ctl[i].xfer = libusb_alloc_transfer(0)))
            return ef_fail(m, EF_ERR_NOMEM, "%s: no memory for transfers", g->label);
    for (int i = 0; i < EF_GSUSB_RX_XFERS; i++) {
        uint8_t *buf = malloc((size_t)len);
        struct libusb_transfer *x = libusb_alloc_transfer(0);
        if (!buf || !x) {
            free(buf);
            libusb_free_transfer(x);
            return ef_fail(m, EF_ERR_NOMEM, "%s: no memory for transfers", g->label);
        }
        libusb_fill_bulk_transfer(x, g->h, g->ep_in, buf, len, gsu_rx_cb, g, 0);
        g->rx[i] = x;
        int r = libusb_submit_transfer(x);
        if (r != 0)
            return ef_fail(m, EF_ERR_IO, "%s: bulk IN submit: %s", g->label, libusb_strerror(r));
        g->rx_active++;
    }
    return EF_OK;
}

static int gsu_open(void *ctx, const ef_canif_cfg_t *c, ef_msg_t *m)
{
    ef_gsusb_t *g = ctx;
    if (!g || !c)
        return ef_fail(m, EF_ERR_ARG, "gs_usb open: NULL");
    ef_gsusb_opts_t o = g->opts;
    ef_gsusb_stats_t zero;
    gsu_close(g); /* a second open starts clean */
    g->fault_msg.text[0] = 0;
    g->opts = o;
    memset(&zero, 0, sizeof zero);
    g->stats = zero;
    const char *name = c->name ? c->name : "";
    char who[64];
    uint32_t spec_rate = 0;
    if (ef_gsusb_spec_is(name)) {
        int rc = ef_gsusb_spec_parse(name, who, sizeof who, &spec_rate, m);
        if (rc != EF_OK)
            return rc;
    } else if (strlen(name) >= sizeof who) {
        return ef_fail(m, EF_ERR_ARG, "gs_usb open: name '%.40s...' too long", name);
    } else {
        snprintf(who, sizeof who, "%s", name);
    }
    snprintf(g->label, sizeof g->label, "gs_usb%s%s", who[0] ? " " : "", who);
    if (c->n_filters < 0 || c->n_filters > EF_CANIF_MAX_FILTERS || (c->n_filters && !c->filters))
        return ef_fail(m, EF_ERR_ARG, "%s: %d filters (0..%d, array needed)", g->label,
                       c->n_filters, EF_CANIF_MAX_FILTERS);
    uint32_t bitrate = c->bitrate ? c->bitrate : spec_rate ? spec_rate : GSU_DEFAULT_BITRATE;
    int rc = gsu_usb_init(&g->usb, m);
    if (rc == EF_OK)
        rc = gsu_find(g, who, m);
    if (rc == EF_OK) {
        /* From here messages name the adapter by serial (or path) whatever named it. */
        snprintf(g->label, sizeof g->label, "gs_usb %s", g->serial[0] ? g->serial : g->path);
        rc = gsu_endpoints(g, m);
    }
    if (rc == EF_OK)
        rc = gsu_claim(g, m);
    if (rc == EF_OK)
        rc = gsu_configure(g, bitrate, m);
    if (rc == EF_OK) {
        g->is_open = 1; /* completions resubmit only while open */
        rc = gsu_start_io(g, m);
    }
    if (rc == EF_OK && c->log) {
        g->log = fopen(c->log, "w");
        if (!g->log)
            rc = ef_fail(m, EF_ERR_IO, "%s: candump log %s: cannot write", g->label, c->log);
    }
    if (rc != EF_OK) {
        ef_msg_t keep;
        snprintf(keep.text, sizeof keep.text, "%s", m ? m->text : "");
        gsu_close(g);
        g->msg = keep;
        return rc;
    }
    memcpy(g->filters, c->filters, sizeof g->filters[0] * (size_t)c->n_filters);
    g->n_filters = c->n_filters;
    snprintf(g->log_if, sizeof g->log_if, "gsusb%u", (unsigned)g->opts.channel);
    g->poll_last = gsu_now() - EF_GSUSB_POLL_MS * 1000u; /* the first poll at once */
    if (!(g->btc.feature & EF_GSUSB_FEAT_GET_STATE)) {
        libusb_free_transfer(g->ctl[0].xfer); /* no GET_STATE: never polled */
        g->ctl[0].xfer = NULL;
    }
    if (!g->with_ts) {
        libusb_free_transfer(g->ctl[1].xfer);
        g->ctl[1].xfer = NULL;
    }
    g->msg.text[0] = 0;
    return EF_OK;
}

static const ef_canif_ops_t gsu_ops = {
    .name = "gs_usb",
    .open = gsu_open,
    .close = gsu_close,
    .send = gsu_send,
    .recv = gsu_recv,
    .flush = gsu_flush,
    .status = gsu_status,
    .error = gsu_error,
    .now_us = gsu_now_us,
};

ef_canif_t ef_gsusb_canif(ef_gsusb_t *g)
{
    ef_canif_t ci = {&gsu_ops, g};
    return ci;
}

/* ---- The list ------------------------------------------------------------------------ */

/* Ask a free adapter for DEVICE_CONFIG and BT_CONST (channel 0), claiming it briefly. */
static void gsu_query(libusb_device_handle *h, ef_gsusb_info_t *e)
{
    int r = libusb_claim_interface(h, GSU_IFACE);
    if (r == LIBUSB_ERROR_BUSY) {
        e->claimed = 1;
        snprintf(e->note, sizeof e->note, "claimed by another program");
        return;
    }
    if (r != 0) {
        snprintf(e->note, sizeof e->note, "cannot claim: %s", libusb_strerror(r));
        return;
    }
    ef_msg_t m;
    ef_gsusb_devcfg_t dc;
    ef_gsusb_btconst_t bc;
    uint8_t b[4];
    ef_gsusb_put32(b, EF_GSUSB_HOST_FORMAT_LE);
    const char *L = "gs_usb";
    if (gsu_ctrl(h, L, 0, EF_GSUSB_BREQ_HOST_FORMAT, 1, b, sizeof b, &m) == EF_OK &&
        gsu_read_devcfg(h, L, &dc, &m) == EF_OK && gsu_read_btconst(h, L, 0, &bc, &m) == EF_OK) {
        e->queried = 1;
        e->channels = dc.channels;
        e->sw_version = dc.sw_version;
        e->hw_version = dc.hw_version;
        e->fclk = bc.fclk;
        e->feature = bc.feature;
    } else {
        snprintf(e->note, sizeof e->note, "%.150s", m.text);
    }
    (void)libusb_release_interface(h, GSU_IFACE);
}

int ef_gsusb_list(ef_gsusb_info_t *out, int max, int *found, ef_msg_t *m)
{
    if ((!out && max > 0) || !found)
        return ef_fail(m, EF_ERR_ARG, "gs_usb list: NULL");
    *found = 0;
    libusb_context *usb;
    int rc = gsu_usb_init(&usb, m);
    if (rc != EF_OK)
        return rc;
    libusb_device **list;
    ssize_t n = libusb_get_device_list(usb, &list);
    if (n < 0) {
        libusb_exit(usb);
        return ef_fail(m, EF_ERR_IO, "gs_usb: listing USB devices: %s", libusb_strerror((int)n));
    }
    for (ssize_t i = 0; i < n; i++) {
        struct libusb_device_descriptor dd;
        if (libusb_get_device_descriptor(list[i], &dd) != 0 ||
            !gsu_id_known(dd.idVendor, dd.idProduct))
            continue;
        int k = (*found)++;
        if (k >= max)
            continue;
        ef_gsusb_info_t *e = &out[k];
        memset(e, 0, sizeof *e);
        e->vid = dd.idVendor;
        e->pid = dd.idProduct;
        gsu_path(list[i], e->path, sizeof e->path);
        libusb_device_handle *h;
        int r = libusb_open(list[i], &h);
        if (r != 0) {
            snprintf(e->note, sizeof e->note, "%s",
                     r == LIBUSB_ERROR_ACCESS ? gsu_access_hint : libusb_strerror(r));
            continue;
        }
        gsu_string(h, dd.iSerialNumber, e->serial, sizeof e->serial);
        gsu_string(h, dd.iProduct, e->product, sizeof e->product);
        if (libusb_kernel_driver_active(h, GSU_IFACE) == 1) {
            /* Detaching would take a CAN network interface away from whoever uses it. */
            e->driver_bound = 1;
            snprintf(e->note, sizeof e->note,
                     "the kernel driver has it (a SocketCAN interface); open detaches it");
        } else {
            gsu_query(h, e);
        }
        libusb_close(h);
    }
    libusb_free_device_list(list, 1);
    libusb_exit(usb);
    return EF_OK;
}
