/* SPDX-License-Identifier: Apache-2.0 */
/* SocketCAN transport: raw CAN socket, error frames, ENOBUFS back-off, candump log. */
#include <errno.h>
#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>

#include "evenfeed/host/can/ef_sockcan.h"

/* Receive buffer asked for each socket (bytes; see ef_sockcan_open()). */
#define EF_SC_RCVBUF         (4 << 20)
#define EF_SC_BACKOFF_MIN_US 100u
#define EF_SC_BACKOFF_MAX_US 10000u

/* Error classes the socket subscribes to (the rest, e.g. lost arbitration, is noise here). */
#define EF_SC_ERR_MASK                                                                             \
    (CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_PROT | CAN_ERR_TRX | CAN_ERR_ACK |                \
     CAN_ERR_BUSOFF | CAN_ERR_BUSERROR | CAN_ERR_RESTARTED)

/* Nanoseconds on the given clock. */
static uint64_t sc_clock_ns(clockid_t clk)
{
    struct timespec ts;
    clock_gettime(clk, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* Monotonic microseconds, wrapping at 2^32. */
uint32_t ef_sockcan_now_us(void)
{
    return (uint32_t)(sc_clock_ns(CLOCK_MONOTONIC) / 1000u);
}

/* Whether errno says the interface is down or gone. */
static int sc_errno_down(int e)
{
    return e == ENETDOWN || e == ENXIO || e == ENODEV;
}

/* Whether errno says the kernel's transmit queue (or the socket's send buffer) is full. */
static int sc_errno_full(int e)
{
    return e == ENOBUFS || e == EAGAIN || e == EWOULDBLOCK;
}

/* One line of candump's log format from a raw SocketCAN id (flags included). */
void ef_sockcan_log_raw(FILE *log, const char *ifname, uint32_t can_id, uint8_t dlc,
                        const uint8_t *data)
{
    if (!log || !data)
        return;
    struct timespec ts;
    char buf[64];
    int n;

    clock_gettime(CLOCK_REALTIME, &ts);
    if (can_id & CAN_ERR_FLAG)
        n = snprintf(buf, sizeof buf, "%08X#", (unsigned)(can_id & (CAN_ERR_MASK | CAN_ERR_FLAG)));
    else if (can_id & CAN_EFF_FLAG)
        n = snprintf(buf, sizeof buf, "%08X#", (unsigned)(can_id & CAN_EFF_MASK));
    else
        n = snprintf(buf, sizeof buf, "%03X#", (unsigned)(can_id & CAN_SFF_MASK));
    if (dlc > CAN_MAX_DLEN)
        dlc = CAN_MAX_DLEN;
    if (can_id & CAN_RTR_FLAG) {
        buf[n++] = 'R';
        if (dlc)
            buf[n++] = "0123456789ABCDEF"[dlc];
    } else {
        for (uint8_t i = 0; i < dlc; i++)
            n += snprintf(buf + n, sizeof buf - (size_t)n, "%02X", data[i]);
    }
    buf[n] = 0;
    fprintf(log, "(%010lld.%06ld) %s %s\n", (long long)ts.tv_sec, ts.tv_nsec / 1000, ifname, buf);
}

/* SocketCAN id (with EFF/RTR flags) of an evenfeed frame. */
static uint32_t sc_raw_id(const ef_can_frame_t *f)
{
    if (f->flags & EF_CAN_FLAG_EFF) {
        return (f->id & CAN_EFF_MASK) | CAN_EFF_FLAG |
               ((f->flags & EF_CAN_FLAG_RTR) ? CAN_RTR_FLAG : 0u);
    }
    return (f->id & CAN_SFF_MASK) | ((f->flags & EF_CAN_FLAG_RTR) ? CAN_RTR_FLAG : 0u);
}

/* Write one evenfeed frame to a candump log. */
void ef_sockcan_log_frame(FILE *log, const char *ifname, const ef_can_frame_t *f)
{
    if (!log || !f)
        return;
    ef_sockcan_log_raw(log, ifname ? ifname : "can?", sc_raw_id(f), f->dlc, f->data);
}

/* Open, configure and bind the raw socket; see ef_sockcan.h. */
int ef_sockcan_open(ef_sockcan_t *s, const char *ifname, const ef_sockcan_filter_t *filters, int n,
                    const char *log_path, ef_msg_t *m)
{
    struct can_filter cf[EF_SOCKCAN_MAX_FILTERS];
    struct sockaddr_can addr;
    can_err_mask_t err_mask = EF_SC_ERR_MASK;
    int off = 0, fd, e;
    unsigned idx;

    if (!s)
        return ef_fail(m, EF_ERR_ARG, "sockcan open: NULL socket");
    memset(s, 0, sizeof *s);
    s->fd = -1;
    s->backoff_us = EF_SC_BACKOFF_MIN_US;
    if (!ifname || !ifname[0])
        return ef_fail(m, EF_ERR_ARG, "sockcan open: no interface name");
    if (strlen(ifname) >= IFNAMSIZ)
        return ef_fail(m, EF_ERR_ARG, "sockcan open: interface name '%.40s...' longer than %d",
                       ifname, IFNAMSIZ - 1);
    if (n < 0 || n > EF_SOCKCAN_MAX_FILTERS || (n > 0 && !filters))
        return ef_fail(m, EF_ERR_ARG, "sockcan open %s: %d filters (0..%d, array needed)", ifname,
                       n, EF_SOCKCAN_MAX_FILTERS);
    snprintf(s->ifname, sizeof s->ifname, "%s", ifname);

    fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC | SOCK_NONBLOCK, CAN_RAW);
    if (fd < 0)
        return ef_fail(m, EF_ERR_IO, "sockcan open %s: socket(PF_CAN): %s (no CAN in this kernel?)",
                       ifname, strerror(errno));
    idx = if_nametoindex(ifname);
    if (idx == 0) {
        e = errno;
        close(fd);
        return ef_fail(m, EF_ERR_IO, "sockcan open %s: no such interface (%s)", ifname,
                       strerror(e));
    }
    for (int i = 0; i < n; i++) {
        cf[i].can_id = filters[i].id;
        cf[i].can_mask = filters[i].mask;
    }
    /* n == 0 keeps the kernel's default filter: everything. */
    if ((n > 0 &&
         setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, cf, (socklen_t)(sizeof cf[0] * (size_t)n))) ||
        setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) ||
        setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &off, sizeof off)) {
        e = errno;
        close(fd);
        return ef_fail(m, EF_ERR_IO, "sockcan open %s: setsockopt(SOL_CAN_RAW): %s", ifname,
                       strerror(e));
    }
    /* Frames a held-back reader has not read yet wait in the socket's receive queue; the
     * default (rmem_default, about 200 kB: some 250 frames) is gone in a few hundred ms of
     * a starved process on a busy bus. 4 MiB where the process may (CAP_NET_ADMIN), else
     * as much as rmem_max allows. The kernel counts what it still drops (SO_RXQ_OVFL). */
    int rcv = EF_SC_RCVBUF, on = 1;
    if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcv, sizeof rcv) != 0)
        (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof rcv);
    (void)setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = (int)idx;
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr)) {
        e = errno;
        close(fd);
        return ef_fail(m, EF_ERR_IO, "sockcan open %s: bind: %s (not a CAN interface?)", ifname,
                       strerror(e));
    }
    if (log_path) {
        s->log = fopen(log_path, "w");
        if (!s->log) {
            e = errno;
            close(fd);
            return ef_fail(m, EF_ERR_IO, "sockcan open %s: candump log %s: %s", ifname, log_path,
                           strerror(e));
        }
    }
    s->fd = fd;
    return EF_OK;
}

/* Close the socket and the log; harmless on NULL or an already closed socket. */
void ef_sockcan_close(ef_sockcan_t *s)
{
    if (!s)
        return;
    if (s->fd >= 0)
        close(s->fd);
    s->fd = -1;
    if (s->log)
        fclose(s->log);
    s->log = NULL;
}

/* Hand one frame to the kernel: 0 when taken, else the errno it met. */
static int sc_write(ef_sockcan_t *s, const ef_can_frame_t *f)
{
    struct can_frame cf;
    ssize_t r;

    memset(&cf, 0, sizeof cf);
    cf.can_id = sc_raw_id(f);
    cf.can_dlc = f->dlc;
    if (!(f->flags & EF_CAN_FLAG_RTR))
        memcpy(cf.data, f->data, f->dlc);
    do {
        r = send(s->fd, &cf, sizeof cf, MSG_DONTWAIT | MSG_NOSIGNAL);
    } while (r < 0 && errno == EINTR);
    if (r < 0)
        return errno;
    if (r != (ssize_t)sizeof cf)
        return EIO;
    s->tx++;
    s->tx_bits += ef_can_frame_bits(f);
    s->bus &= ~EF_SOCKCAN_DOWN;
    s->backoff_us = EF_SC_BACKOFF_MIN_US;
    if (s->log)
        ef_sockcan_log_raw(s->log, s->ifname, cf.can_id, cf.can_dlc, cf.data);
    return 0;
}

/* Start (or lengthen) the back-off after the kernel refused a frame for a full queue. */
static void sc_backoff(ef_sockcan_t *s)
{
    s->enobufs++;
    if (s->backoff_us < EF_SC_BACKOFF_MIN_US)
        s->backoff_us = EF_SC_BACKOFF_MIN_US;
    s->backoff_until_ns = sc_clock_ns(CLOCK_MONOTONIC) + (uint64_t)s->backoff_us * 1000u;
    s->backoff_us *= 2u;
    if (s->backoff_us > EF_SC_BACKOFF_MAX_US)
        s->backoff_us = EF_SC_BACKOFF_MAX_US;
}

/* Map a write errno other than "queue full" to a code and a message. */
static int sc_send_error(ef_sockcan_t *s, int e, const char *what)
{
    if (sc_errno_down(e)) {
        s->bus |= EF_SOCKCAN_DOWN;
        return ef_fail(&s->msg, EF_ERR_BUS, "sockcan %s: %s: interface down (%s)", s->ifname, what,
                       strerror(e));
    }
    return ef_fail(&s->msg, EF_ERR_IO, "sockcan %s: %s: %s", s->ifname, what, strerror(e));
}

/* Append a frame to the backlog ring (the caller checked there is room). */
static void sc_hold(ef_sockcan_t *s, const ef_can_frame_t *f)
{
    s->backlog[(s->bl_head + s->bl_count) % EF_SOCKCAN_BACKLOG] = *f;
    s->bl_count++;
}

/* Send what the backlog holds, oldest first, until it is empty or the kernel refuses. */
int ef_sockcan_flush(ef_sockcan_t *s)
{
    if (!s || s->fd < 0)
        return EF_ERR_ARG;
    while (s->bl_count > 0) {
        int e;
        if (sc_clock_ns(CLOCK_MONOTONIC) < s->backoff_until_ns)
            return EF_OK; /* still backing off: frames stay held */
        e = sc_write(s, &s->backlog[s->bl_head]);
        if (e == 0) {
            s->bl_head = (s->bl_head + 1u) % EF_SOCKCAN_BACKLOG;
            s->bl_count--;
        } else if (sc_errno_full(e)) {
            sc_backoff(s);
            return EF_OK;
        } else {
            return sc_send_error(s, e, "flush");
        }
    }
    return EF_OK;
}

/* Send one frame, or hold it behind earlier held frames / during a back-off. */
int ef_sockcan_send(ef_sockcan_t *s, const ef_can_frame_t *f)
{
    int rc, e;

    if (!s || !f || s->fd < 0)
        return EF_ERR_ARG;
    if (f->dlc > EF_CAN_MAX_DLC)
        return ef_fail(&s->msg, EF_ERR_ARG, "sockcan %s: send: dlc %u > 8", s->ifname, f->dlc);
    if (s->bus & EF_SOCKCAN_BUS_OFF)
        return ef_fail(&s->msg, EF_ERR_BUS, "sockcan %s: send: controller is bus-off", s->ifname);
    rc = ef_sockcan_flush(s);
    if (rc != EF_OK)
        return rc;
    if (s->bl_count > 0 || sc_clock_ns(CLOCK_MONOTONIC) < s->backoff_until_ns) {
        if (s->bl_count >= EF_SOCKCAN_BACKLOG)
            return ef_fail(&s->msg, EF_ERR_AGAIN, "sockcan %s: send: TX queue and backlog full",
                           s->ifname);
        sc_hold(s, f); /* keeps the order behind the frames already held */
        return EF_OK;
    }
    e = sc_write(s, f);
    if (e == 0)
        return EF_OK;
    if (sc_errno_full(e)) {
        sc_backoff(s);
        sc_hold(s, f);
        return EF_OK;
    }
    return sc_send_error(s, e, "send");
}

/* Update the bus conditions from one error frame. */
static void sc_error_frame(ef_sockcan_t *s, const struct can_frame *cf)
{
    s->err_frames++;
    if (cf->can_id & CAN_ERR_BUSOFF)
        s->bus |= EF_SOCKCAN_BUS_OFF;
    if (cf->can_id & CAN_ERR_CRTL) {
        if (cf->data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))
            s->bus |= EF_SOCKCAN_ERROR_PASSIVE;
        if (cf->data[1] & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING))
            s->bus |= EF_SOCKCAN_ERROR_WARNING;
    }
    if (cf->can_id & CAN_ERR_RESTARTED) {
        s->bus |= EF_SOCKCAN_RESTARTED;
        s->bus &= ~EF_SOCKCAN_BUS_OFF;
    }
}

/* Wait until the socket is readable (or has an error) or timeout_ns passes: 1 ready, 0 not. */
static int sc_wait(int fd, uint64_t timeout_ns)
{
    struct pollfd p = {.fd = fd, .events = POLLIN};
    struct timespec ts = {.tv_sec = (time_t)(timeout_ns / 1000000000u),
                          .tv_nsec = (long)(timeout_ns % 1000000000u)};
    int r = ppoll(&p, 1, &ts, NULL);
    return r > 0;
}

/* Receive one data frame within timeout_us, consuming error frames on the way; *t_ns: the
 * clock's last reading before the frame was read (the frame's receive time, without a clock
 * call of its own: under User-Mode Linux every system call costs tens of microseconds). */
static int sc_recv(ef_sockcan_t *s, ef_can_frame_t *f, uint32_t timeout_us, uint64_t *t_ns)
{
    uint64_t deadline, now;
    int saw_error = 0;

    if (!s || !f || s->fd < 0)
        return EF_ERR_ARG;
    now = sc_clock_ns(CLOCK_MONOTONIC);
    deadline = now + (uint64_t)timeout_us * 1000u;
    for (;;) {
        struct can_frame cf;
        char ctl[CMSG_SPACE(sizeof(uint32_t))];
        struct iovec iov = {&cf, sizeof cf};
        struct msghdr mh;
        memset(&mh, 0, sizeof mh);
        mh.msg_iov = &iov;
        mh.msg_iovlen = 1;
        mh.msg_control = ctl;
        mh.msg_controllen = sizeof ctl;
        ssize_t r = recvmsg(s->fd, &mh, MSG_DONTWAIT);
        for (struct cmsghdr *c = r >= 0 ? CMSG_FIRSTHDR(&mh) : NULL; c; c = CMSG_NXTHDR(&mh, c))
            if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
                uint32_t d;
                memcpy(&d, CMSG_DATA(c), sizeof d);
                s->rx_overrun = d; /* the kernel's running count for this socket */
            }
        if (r < 0) {
            int e = errno;
            if (e == EINTR)
                continue;
            if (!sc_errno_full(e)) {
                if (sc_errno_down(e)) {
                    s->bus |= EF_SOCKCAN_DOWN;
                    return ef_fail(&s->msg, EF_ERR_BUS, "sockcan %s: recv: interface down (%s)",
                                   s->ifname, strerror(e));
                }
                return ef_fail(&s->msg, EF_ERR_IO, "sockcan %s: recv: %s", s->ifname, strerror(e));
            }
            now = sc_clock_ns(CLOCK_MONOTONIC);
            if (saw_error || now >= deadline || !sc_wait(s->fd, deadline - now))
                return EF_ERR_AGAIN;
            continue;
        }
        if (r != (ssize_t)sizeof cf)
            return ef_fail(&s->msg, EF_ERR_IO, "sockcan %s: recv: %zd bytes, not a CAN frame",
                           s->ifname, r);
        if (cf.can_dlc > CAN_MAX_DLEN)
            cf.can_dlc = CAN_MAX_DLEN;
        if (s->log)
            ef_sockcan_log_raw(s->log, s->ifname, cf.can_id, cf.can_dlc, cf.data);
        if (cf.can_id & CAN_ERR_FLAG) {
            sc_error_frame(s, &cf);
            saw_error = 1;
            continue;
        }
        memset(f, 0, sizeof *f);
        if (cf.can_id & CAN_EFF_FLAG) {
            f->id = cf.can_id & CAN_EFF_MASK;
            f->flags |= EF_CAN_FLAG_EFF;
        } else {
            f->id = cf.can_id & CAN_SFF_MASK;
        }
        if (cf.can_id & CAN_RTR_FLAG)
            f->flags |= EF_CAN_FLAG_RTR;
        f->dlc = cf.can_dlc;
        if (!(cf.can_id & CAN_RTR_FLAG))
            memcpy(f->data, cf.data, cf.can_dlc);
        s->rx++;
        s->bus &= ~EF_SOCKCAN_DOWN;
        if (t_ns)
            *t_ns = now;
        return EF_OK;
    }
}

/* Receive one data frame within timeout_us (see ef_sockcan.h). */
int ef_sockcan_recv(ef_sockcan_t *s, ef_can_frame_t *f, uint32_t timeout_us)
{
    return sc_recv(s, f, timeout_us, NULL);
}

/* HAL send operation over ef_sockcan_send(). */
static int sc_port_send(void *ctx, const ef_can_frame_t *f)
{
    return ef_sockcan_send((ef_sockcan_t *)ctx, f);
}

/* The CAN HAL port of an open socket. */
ef_can_port_t ef_sockcan_port(ef_sockcan_t *s)
{
    ef_can_port_t p = {sc_port_send, s};
    return p;
}

/* Error frame injection (see ef_sockcan.h): a plain write, bypassing log and counters. */
int ef_sockcan_inject_error(ef_sockcan_t *s, uint32_t err_class)
{
    struct can_frame cf;
    ssize_t n;

    if (!s || s->fd < 0)
        return EF_ERR_ARG;
    memset(&cf, 0, sizeof cf);
    cf.can_id = CAN_ERR_FLAG | (err_class & CAN_ERR_MASK);
    cf.can_dlc = CAN_ERR_DLC;
    n = write(s->fd, &cf, sizeof cf);
    if (n == (ssize_t)sizeof cf)
        return EF_OK;
    return ef_fail(&s->msg, EF_ERR_IO, "%s", n < 0 ? strerror(errno) : strerror(EIO));
}

/* ---- The socket as an ef_canif_t ---------------------------------------------------- */

static int sc_if_open(void *ctx, const ef_canif_cfg_t *c, ef_msg_t *m)
{
    return ef_sockcan_open(ctx, c->name, c->filters, c->n_filters, c->log, m);
}

static void sc_if_close(void *ctx)
{
    ef_sockcan_close(ctx);
}

static int sc_if_send(void *ctx, const ef_can_frame_t *f)
{
    return ef_sockcan_send(ctx, f);
}

static int sc_if_recv(void *ctx, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us)
{
    /* The clock's reading just before the frame was read: SO_TIMESTAMP would give the
     * kernel's, which vcan and most drivers only take at the same software moment anyway. */
    uint64_t t_ns = 0;
    int rc = sc_recv(ctx, f, timeout_us, &t_ns);
    if (rc == EF_OK && ts_us)
        *ts_us = (uint32_t)(t_ns / 1000u);
    return rc;
}

static int sc_if_flush(void *ctx)
{
    return ef_sockcan_flush(ctx);
}

static void sc_if_status(void *ctx, uint32_t clear, ef_canif_status_t *st)
{
    ef_sockcan_t *s = ctx;
    st->state = s->fd < 0 ? EF_CANIF_STATE_STOPPED : ef_canif_state_of(s->bus);
    st->seen = s->bus;
    st->err_frames = s->err_frames;
    st->tx_pending = s->bl_count;
    st->tx_full = s->enobufs;
    st->tec = st->rec = -1;
    st->tx = s->tx;
    st->rx = s->rx;
    st->rx_overrun = s->rx_overrun;
    st->tx_bits = s->tx_bits;
    s->bus &= ~clear;
}

static const char *sc_if_error(void *ctx)
{
    return ((const ef_sockcan_t *)ctx)->msg.text;
}

static uint32_t sc_if_now_us(void *ctx)
{
    (void)ctx;
    return ef_sockcan_now_us();
}

static const ef_canif_ops_t sc_if_ops = {
    .name = "socketcan",
    .open = sc_if_open,
    .close = sc_if_close,
    .send = sc_if_send,
    .recv = sc_if_recv,
    .flush = sc_if_flush,
    .status = sc_if_status,
    .error = sc_if_error,
    .now_us = sc_if_now_us,
};

ef_canif_t ef_sockcan_canif(ef_sockcan_t *s)
{
    ef_canif_t ci = {&sc_if_ops, s};
    return ci;
}
