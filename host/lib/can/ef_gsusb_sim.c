/* SPDX-License-Identifier: Apache-2.0 */
/* The simulated gs_usb adapter: a FunctionFS gadget made through configfs, bridging the
 * gs_usb protocol (ef_gsusb_wire.h) to SocketCAN (ef_gsusb_sim.h). Facts about FunctionFS
 * used here are those of Linux 6.1's f_fs.c: ep0 yields events, a SETUP event is the last
 * of a batch and leaves the request pending until ep0 is read (OUT) or written (IN); the
 * wrong one stalls it; writes are cut to wLength; reading an IN endpoint halts it. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <net/if.h>
#include <poll.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mount.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <linux/aio_abi.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/usb/ch9.h>
#include <linux/usb/functionfs.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/host/can/ef_gsusb_sim.h"

/* candleLight's answers (STM32F072: bxCAN on a 48 MHz clock). */
#define GSS_FEATURES                                                                               \
    (EF_GSUSB_FEAT_LISTEN_ONLY | EF_GSUSB_FEAT_LOOP_BACK | EF_GSUSB_FEAT_ONE_SHOT |                \
     EF_GSUSB_FEAT_HW_TIMESTAMP | EF_GSUSB_FEAT_IDENTIFY | EF_GSUSB_FEAT_PAD_PKTS |                \
     EF_GSUSB_FEAT_BERR | EF_GSUSB_FEAT_GET_STATE)
/* MODE flags a start may carry: those of the features above that are modes. */
#define GSS_MODE_OK                                                                                \
    (EF_GSUSB_MODE_LISTEN_ONLY | EF_GSUSB_MODE_LOOP_BACK | EF_GSUSB_MODE_ONE_SHOT |                \
     EF_GSUSB_MODE_HW_TIMESTAMP | EF_GSUSB_MODE_PAD_PKTS | EF_GSUSB_MODE_BERR)
#define GSS_SW_VERSION 2u
#define GSS_HW_VERSION 1u
/* Bitrate before any BITTIMING (pacing only; the host always sets one before a start). */
#define GSS_DEFAULT_BITRATE 1000000u
/* Bulk packet sizes: full speed 64, high speed 512 (the only sizes bulk allows there). */
#define GSS_FS_PACKET 64u
#define GSS_HS_PACKET 512u
/* Pacing with coarse timers (UML wakes a sleeper up to a tick late): the adapter sleeps
 * only once it is GSS_PACE_AHEAD_NS ahead of the bus, and a frame that comes less than
 * GSS_PACE_SLACK_NS after the bus went free still follows the one before back to back, so
 * a late wake-up is caught up on and the average rate is the bitrate. After a longer gap
 * the bus was idle and the frame starts now. */
#define GSS_PACE_AHEAD_NS 2000000u
#define GSS_PACE_SLACK_NS 20000000u
/* Transfers kept queued on each bulk endpoint (kernel AIO, which FunctionFS supports). One
 * blocking read or write at a time leaves the endpoint idle between transfers: under
 * User-Mode Linux each costs a dummy_hcd timer period plus two context switches, which
 * held the adapter to about 640 frames/s where the bus takes 7400. With several queued, a
 * timer period completes as many as the host has transfers waiting for. */
#define GSS_AIO_DEPTH 8
/* Longest wait for an IN completion while frames may be arriving for the queue (ns). */
#define GSS_IN_POLL_NS 1000000
/* Messages about one kind of bad input: the first ones, then every 1000th. */
#define GSS_REPORT_FIRST 20u

/* One frame waiting for ep1, with what the channel's mode says about its encoding. */
typedef struct {
    ef_gsusb_frame_t f;
    uint16_t pad_to; /* pad the transfer to this size (0: none) */
} gss_item_t;

/* A thread and whether it has left its loop (ef_gsusb_sim_stop() signals until it has). */
typedef struct {
    pthread_t id;
    int running;
    volatile int exited;
} gss_thread_t;

struct ef_gsusb_sim_s;

/* One CAN channel: its socket and controller state (under the adapter's lock). */
typedef struct {
    struct ef_gsusb_sim_s *s;
    unsigned idx;
    int fd;
    gss_thread_t th;
    int started;
    uint32_t flags; /* MODE flags of the start */
    ef_gsusb_bittiming_t bt;
    uint32_t bitrate;
    int bt_refused; /* a BITTIMING was refused: stall the next MODE */
    int berr;
    int overflow;         /* the next received frame carries EF_GSUSB_FLAG_OVERFLOW */
    uint32_t rx_n;        /* frames received from the bus (the bus-off and overflow faults) */
    int bus_off;          /* the bus-off fault happened: GET_STATE says so */
    int mode_pending;     /* a MODE request's data is being read and applied (ep0 thread) */
    uint64_t bus_free_ns; /* when the last frame sent left the bus (ep2 thread only) */
} gss_chan_t;

struct ef_gsusb_sim_s {
    ef_gsusb_sim_cfg_t cfg;
    ef_gsusb_btconst_t bc;
    char name[33], udc[64];
    char gadget[256], ffs[256];
    int made_ffs_dir, mounted, bound;
    int ep0, ep1, ep2;
    pthread_mutex_t lk;
    pthread_cond_t cv;
    volatile int stop;
    int enabled, ever_enabled;
    uint16_t in_packet; /* ep1's max packet size at the speed enabled */
    gss_chan_t ch[EF_GSUSB_MAX_CHANNELS];
    gss_item_t *q;
    unsigned qhead, qn;
    gss_thread_t th_ep0, th_ep1, th_ep2;
    uint64_t t0_ns;
    uint32_t in_sent;
    int halted;
    ef_gsusb_sim_stats_t st;
};

/* ---- small helpers ------------------------------------------------------------------- */

/* Monotonic nanoseconds. */
static uint64_t gss_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* The adapter's timestamp: microseconds since start plus ts_start, wrapping at 2^32. */
static uint32_t gss_ts(const struct ef_gsusb_sim_s *s)
{
    return (uint32_t)((gss_now_ns() - s->t0_ns) / 1000u) + s->cfg.ts_start;
}

/* Sleep until the monotonic time t (ns); a signal ends it early. */
static void gss_sleep_until(uint64_t t)
{
    struct timespec ts = {(time_t)(t / 1000000000u), (long)(t % 1000000000u)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
}

/* Messages go to stderr as one line each, prefixed like the command's. */
static void gss_say(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void gss_say(const char *fmt, ...)
{
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    fprintf(stderr, "sim-adapter: %s\n", line);
}

/* Whether the count-th occurrence of a bad input is reported: a flood of bad frames must
 * not turn into a flood of lines, but the first ones and a trace of the rest must show. */
static int gss_report(uint64_t count)
{
    return count <= GSS_REPORT_FIRST || count % 1000u == 0;
}

static void gss_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

/* Write value into the configfs attribute gadget/rel. */
static int gss_attr(const struct ef_gsusb_sim_s *s, const char *rel, const char *value, ef_msg_t *m)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", s->gadget, rel);
    int fd = open(path, O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0)
        return ef_fail(m, EF_ERR_IO, "open %s: %s", path, strerror(errno));
    size_t n = strlen(value);
    ssize_t w = write(fd, value, n);
    int e = errno;
    close(fd);
    if (w != (ssize_t)n)
        return ef_fail(m, EF_ERR_IO, "write '%s' to %s: %s", value, path,
                       w < 0 ? strerror(e) : "short write");
    return EF_OK;
}

/* mkdir gadget/rel (rel NULL: the gadget itself). */
static int gss_mkdir(const struct ef_gsusb_sim_s *s, const char *rel, ef_msg_t *m)
{
    char path[512];
    snprintf(path, sizeof path, "%s%s%s", s->gadget, rel ? "/" : "", rel ? rel : "");
    if (mkdir(path, 0755) != 0)
        return ef_fail(m, EF_ERR_IO, "mkdir %s: %s", path, strerror(errno));
    return EF_OK;
}

/* rmdir (or unlink, for the configuration's link) gadget/rel; a missing one is fine. */
static void gss_rm(const struct ef_gsusb_sim_s *s, const char *rel, int is_link)
{
    char path[512];
    snprintf(path, sizeof path, "%s%s%s", s->gadget, rel ? "/" : "", rel ? rel : "");
    int rc = is_link ? unlink(path) : rmdir(path);
    if (rc != 0 && errno != ENOENT)
        gss_say("cleanup: remove %s: %s", path, strerror(errno));
}

/* ---- configfs and FunctionFS: making and unmaking the gadget -------------------------- */

/* Remove the gadget in reverse order of gss_make(): unbind, unmount, link, configuration,
 * function, strings, gadget. Every step tolerates a missing piece, so the same code
 * removes what a crashed run left behind and what this run made. */
static void gss_unmake(struct ef_gsusb_sim_s *s)
{
    char path[512], rel[96];
    struct stat sb;
    if (stat(s->gadget, &sb) == 0) {
        snprintf(path, sizeof path, "%s/UDC", s->gadget);
        int fd = open(path, O_RDWR | O_CLOEXEC);
        if (fd >= 0) {
            char cur[64] = {0};
            ssize_t r = read(fd, cur, sizeof cur - 1);
            /* An empty UDC attribute reads as "\n": only write to a bound one. */
            if (r > 1 && write(fd, "\n", 1) != 1)
                gss_say("cleanup: unbind %s: %s", path, strerror(errno));
            close(fd);
        }
    }
    s->bound = 0;
    /* EINVAL: nothing mounted there; ENOENT: no directory. Both are fine. */
    if (umount(s->ffs) != 0 && errno == EBUSY && umount2(s->ffs, MNT_DETACH) != 0)
        gss_say("cleanup: umount %s: %s", s->ffs, strerror(errno));
    s->mounted = 0;
    /* The default directory is ours by name (a killed run's too); a given one only when
     * this run made it. */
    if (s->made_ffs_dir || (!s->cfg.ffs_dir && stat(s->ffs, &sb) == 0))
        rmdir(s->ffs);
    s->made_ffs_dir = 0;
    if (stat(s->gadget, &sb) != 0)
        return;
    snprintf(rel, sizeof rel, "configs/c.1/ffs.%s", s->name);
    gss_rm(s, rel, 1);
    gss_rm(s, "configs/c.1/strings/0x409", 0);
    gss_rm(s, "configs/c.1", 0);
    snprintf(rel, sizeof rel, "functions/ffs.%s", s->name);
    gss_rm(s, rel, 0);
    gss_rm(s, "strings/0x409", 0);
    gss_rm(s, NULL, 0);
}

/* FunctionFS descriptors (V2): interface 0, vendor specific, bulk IN then bulk OUT, for
 * full and high speed. The IN endpoint comes first, so it is FunctionFS's file ep1 and
 * the OUT one ep2; the UDC picks the addresses (dummy_hcd: 0x81, 0x02). */
static size_t gss_descs(uint8_t *b)
{
    size_t n = 0;
    ef_gsusb_put32(b + n, FUNCTIONFS_DESCRIPTORS_MAGIC_V2);
    n += 8; /* length below */
    ef_gsusb_put32(b + n, FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC);
    n += 4;
    ef_gsusb_put32(b + n, 3); /* fs_count */
    n += 4;
    ef_gsusb_put32(b + n, 3); /* hs_count */
    n += 4;
    for (int speed = 0; speed < 2; speed++) {
        uint16_t mps = speed ? GSS_HS_PACKET : GSS_FS_PACKET;
        const uint8_t intf[9] = {9, USB_DT_INTERFACE, 0, 0, 2, USB_CLASS_VENDOR_SPEC, 0xFF, 0xFF,
                                 1};
        memcpy(b + n, intf, sizeof intf);
        n += sizeof intf;
        for (int e = 0; e < 2; e++) {
            b[n] = USB_DT_ENDPOINT_SIZE;
            b[n + 1] = USB_DT_ENDPOINT;
            b[n + 2] = e == 0 ? (1 | USB_DIR_IN) : (2 | USB_DIR_OUT);
            b[n + 3] = USB_ENDPOINT_XFER_BULK;
            gss_put16(b + n + 4, mps);
            b[n + 6] = 0;
            n += USB_DT_ENDPOINT_SIZE;
        }
    }
    ef_gsusb_put32(b + 4, (uint32_t)n);
    return n;
}

/* FunctionFS strings: one (the interface's, index 1) in US English. */
static size_t gss_strings(uint8_t *b, size_t cap, const char *intf)
{
    size_t len = strlen(intf) + 1, n = 16 + 2 + len;
    if (n > cap)
        return 0;
    ef_gsusb_put32(b, FUNCTIONFS_STRINGS_MAGIC);
    ef_gsusb_put32(b + 4, (uint32_t)n);
    ef_gsusb_put32(b + 8, 1);  /* str_count */
    ef_gsusb_put32(b + 12, 1); /* lang_count */
    gss_put16(b + 16, 0x0409);
    memcpy(b + 18, intf, len);
    return n;
}

/* Pick the UDC: the configured one, or the first of /sys/class/udc by name. */
static int gss_pick_udc(struct ef_gsusb_sim_s *s, ef_msg_t *m)
{
    if (s->cfg.udc) {
        if (strlen(s->cfg.udc) >= sizeof s->udc)
            return ef_fail(m, EF_ERR_ARG, "UDC name '%s' too long", s->cfg.udc);
        snprintf(s->udc, sizeof s->udc, "%s", s->cfg.udc);
        return EF_OK;
    }
    DIR *d = opendir("/sys/class/udc");
    if (!d)
        return ef_fail(m, EF_ERR_IO,
                       "no USB device controller: /sys/class/udc: %s (the kernel needs "
                       "USB_GADGET and a UDC, e.g. USB_DUMMY_HCD)",
                       strerror(errno));
    struct dirent *e;
    s->udc[0] = 0;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || strlen(e->d_name) >= sizeof s->udc)
            continue;
        if (!s->udc[0] || strcmp(e->d_name, s->udc) < 0)
            memcpy(s->udc, e->d_name, strlen(e->d_name) + 1); /* fits: checked above */
    }
    closedir(d);
    if (!s->udc[0])
        return ef_fail(m, EF_ERR_IO, "no USB device controller in /sys/class/udc");
    return EF_OK;
}

/* Make the gadget in configfs, mount FunctionFS and write the descriptors. */
static int gss_make(struct ef_gsusb_sim_s *s, ef_msg_t *m)
{
    char v[64], rel[96], path[512], target[512];
    uint8_t buf[256];
    int rc;
    if ((rc = gss_mkdir(s, NULL, m)) != EF_OK)
        return rc;
    snprintf(v, sizeof v, "0x%04x", s->cfg.vid);
    if ((rc = gss_attr(s, "idVendor", v, m)) != EF_OK)
        return rc;
    snprintf(v, sizeof v, "0x%04x", s->cfg.pid);
    if ((rc = gss_attr(s, "idProduct", v, m)) != EF_OK)
        return rc;
    snprintf(v, sizeof v, "0x%04x", s->cfg.bcd_device);
    if ((rc = gss_attr(s, "bcdDevice", v, m)) != EF_OK ||
        (rc = gss_attr(s, "bcdUSB", "0x0200", m)) != EF_OK ||
        (rc = gss_mkdir(s, "strings/0x409", m)) != EF_OK ||
        (rc = gss_attr(s, "strings/0x409/manufacturer", "evenfeed", m)) != EF_OK ||
        (rc = gss_attr(s, "strings/0x409/product",
                       "candleLight USB to CAN adapter (evenfeed simulation)", m)) != EF_OK ||
        (rc = gss_attr(s, "strings/0x409/serialnumber", s->cfg.serial, m)) != EF_OK ||
        (rc = gss_mkdir(s, "configs/c.1", m)) != EF_OK ||
        (rc = gss_attr(s, "configs/c.1/MaxPower", "100", m)) != EF_OK)
        return rc;
    snprintf(rel, sizeof rel, "functions/ffs.%s", s->name);
    if ((rc = gss_mkdir(s, rel, m)) != EF_OK)
        return rc;
    /* The configuration's only function, hence interface 0: gs_usb addresses its channel
     * requests to wIndex 0, and FunctionFS forwards only its own interfaces' requests. */
    snprintf(target, sizeof target, "%s/functions/ffs.%s", s->gadget, s->name);
    snprintf(path, sizeof path, "%s/configs/c.1/ffs.%s", s->gadget, s->name);
    if (symlink(target, path) != 0)
        return ef_fail(m, EF_ERR_IO, "link %s: %s", path, strerror(errno));

    if (mkdir(s->ffs, 0755) == 0)
        s->made_ffs_dir = 1;
    else if (errno != EEXIST)
        return ef_fail(m, EF_ERR_IO, "mkdir %s: %s", s->ffs, strerror(errno));
    if (mount(s->name, s->ffs, "functionfs", 0, NULL) != 0)
        return ef_fail(m, EF_ERR_IO,
                       "mount -t functionfs %s %s: %s (the kernel needs "
                       "USB_CONFIGFS_F_FS)",
                       s->name, s->ffs, strerror(errno));
    s->mounted = 1;

    snprintf(path, sizeof path, "%s/ep0", s->ffs);
    if ((s->ep0 = open(path, O_RDWR | O_CLOEXEC)) < 0)
        return ef_fail(m, EF_ERR_IO, "open %s: %s", path, strerror(errno));
    size_t n = gss_descs(buf);
    if (write(s->ep0, buf, n) != (ssize_t)n)
        return ef_fail(m, EF_ERR_IO, "write descriptors to %s: %s", path, strerror(errno));
    n = gss_strings(buf, sizeof buf, "gs_usb");
    if (write(s->ep0, buf, n) != (ssize_t)n)
        return ef_fail(m, EF_ERR_IO, "write strings to %s: %s", path, strerror(errno));
    snprintf(path, sizeof path, "%s/ep1", s->ffs);
    if ((s->ep1 = open(path, O_RDWR | O_CLOEXEC)) < 0)
        return ef_fail(m, EF_ERR_IO, "open %s: %s", path, strerror(errno));
    snprintf(path, sizeof path, "%s/ep2", s->ffs);
    if ((s->ep2 = open(path, O_RDWR | O_CLOEXEC)) < 0)
        return ef_fail(m, EF_ERR_IO, "open %s: %s", path, strerror(errno));
    return EF_OK;
}

/* ---- kernel AIO on the endpoints (no libaio: the four system calls) -------------------- */

static int gss_io_setup(aio_context_t *ctx)
{
    *ctx = 0;
    return (int)syscall(SYS_io_setup, GSS_AIO_DEPTH, ctx);
}

static void gss_io_destroy(aio_context_t ctx)
{
    /* Waits for (or cancels) what is still queued, so the buffers outlive it. */
    (void)syscall(SYS_io_destroy, ctx);
}

/* Queue one read or write of n bytes at buf on fd; 0 when queued. */
static int gss_io_submit(aio_context_t ctx, struct iocb *cb, int fd, int write, void *buf, size_t n,
                         unsigned slot)
{
    memset(cb, 0, sizeof *cb);
    cb->aio_fildes = (uint32_t)fd;
    cb->aio_lio_opcode = write ? IOCB_CMD_PWRITE : IOCB_CMD_PREAD;
    cb->aio_buf = (uint64_t)(uintptr_t)buf;
    cb->aio_nbytes = n;
    cb->aio_data = slot;
    struct iocb *list[1] = {cb};
    return syscall(SYS_io_submit, ctx, 1L, list) == 1 ? 0 : -1;
}

/* Completions, at least one unless timeout_ns passes (< 0: no bound) or a signal comes. */
static long gss_io_wait(aio_context_t ctx, struct io_event *ev, long timeout_ns)
{
    struct timespec t = {timeout_ns / 1000000000L, timeout_ns % 1000000000L};
    return syscall(SYS_io_getevents, ctx, 1L, (long)GSS_AIO_DEPTH, ev, timeout_ns < 0 ? NULL : &t);
}

/* ---- the queue toward the host (ep1) ------------------------------------------------- */

/* Queue item for channel c (lock held): the channel's mode decides the timestamp and the
 * padding. Returns 0 when the queue is full. */
static int gss_push(struct ef_gsusb_sim_s *s, const gss_chan_t *c, ef_gsusb_frame_t *f)
{
    if (s->qn >= s->cfg.rx_queue)
        return 0;
    gss_item_t *it = &s->q[(s->qhead + s->qn) % s->cfg.rx_queue];
    it->f = *f;
    it->f.has_ts = (c->flags & EF_GSUSB_MODE_HW_TIMESTAMP) != 0;
    it->f.ts_us = gss_ts(s);
    it->pad_to = (c->flags & EF_GSUSB_MODE_PAD_PKTS) ? s->in_packet : 0;
    s->qn++;
    pthread_cond_broadcast(&s->cv);
    return 1;
}

/* Queue a received frame (lock held): dropped when the queue is full, and then the
 * channel's next received frame says so with EF_GSUSB_FLAG_OVERFLOW. */
static void gss_push_rx(struct ef_gsusb_sim_s *s, gss_chan_t *c, ef_gsusb_frame_t *f)
{
    f->echo_id = EF_GSUSB_ECHO_RX;
    f->flags = c->overflow ? EF_GSUSB_FLAG_OVERFLOW : 0;
    if (s->cfg.faults & EF_GSUSB_SIM_F_BAD_CHANNEL)
        f->channel = 5;
    c->rx_n++;
    if ((s->cfg.faults & EF_GSUSB_SIM_F_OVERFLOW) && c->rx_n % EF_GSUSB_SIM_FAULT_AFTER == 0)
        f->flags |= EF_GSUSB_FLAG_OVERFLOW;
    if ((s->cfg.faults & EF_GSUSB_SIM_F_BUS_OFF) && c->rx_n == EF_GSUSB_SIM_FAULT_AFTER) {
        /* SocketCAN's error frame for bus-off, which gs_usb carries unchanged. */
        ef_gsusb_frame_t e;
        memset(&e, 0, sizeof e);
        e.echo_id = EF_GSUSB_ECHO_RX;
        e.can_id = EF_GSUSB_ID_ERR | CAN_ERR_BUSOFF;
        e.dlc = CAN_ERR_DLC;
        e.channel = f->channel;
        c->bus_off = 1;
        gss_say("fault bus-off: channel %u reports bus-off after %u received frames", c->idx,
                c->rx_n);
        (void)gss_push(s, c, &e);
    }
    if (!gss_push(s, c, f)) {
        c->overflow = 1;
        if (gss_report(++s->st.rx_overflow))
            gss_say("channel %u: RX queue full (%u frames): received frame dropped (%llu so "
                    "far)",
                    c->idx, s->cfg.rx_queue, (unsigned long long)s->st.rx_overflow);
        return;
    }
    c->overflow = 0;
    s->st.rx++;
}

/* Halt ep1 (fault stall-in): FunctionFS halts an IN endpoint that is read. */
static void gss_halt_in(struct ef_gsusb_sim_s *s)
{
    uint8_t b;
    ssize_t r = read(s->ep1, &b, 1);
    gss_say("fault stall-in: ep1 halted after %u frames (%s)", s->in_sent,
            r < 0 && errno == EBADMSG ? "ok" : strerror(errno));
    s->halted = 1;
}

/* Encode queue item it for ep1 into buf (the faults that cut or halt apply here); its size. */
static size_t gss_in_encode(struct ef_gsusb_sim_s *s, const gss_item_t *it, uint8_t *buf)
{
    size_t n = ef_gsusb_frame_encode(&it->f, buf);
    if (it->pad_to > n && it->pad_to <= GSS_HS_PACKET) {
        memset(buf + n, 0, it->pad_to - n);
        n = it->pad_to;
    }
    s->in_sent++;
    if ((s->cfg.faults & EF_GSUSB_SIM_F_BAD_FRAME) && s->in_sent % 50u == 0)
        n = 19; /* cut short: the host must refuse it, not read past it */
    return n;
}

/* ep1's thread: send the queue's frames to the host, one transfer each, up to
 * GSS_AIO_DEPTH of them queued on the endpoint at once (in order: FunctionFS completes one
 * endpoint's requests in the order they were queued). */
static void *gss_ep1_main(void *arg)
{
    struct ef_gsusb_sim_s *s = arg;
    uint8_t buf[GSS_AIO_DEPTH][GSS_HS_PACKET];
    struct iocb cb[GSS_AIO_DEPTH];
    int busy[GSS_AIO_DEPTH] = {0};
    unsigned inflight = 0;
    aio_context_t ctx;
    if (gss_io_setup(&ctx) != 0) {
        gss_say("ep1: io_setup: %s", strerror(errno));
        s->th_ep1.exited = 1;
        return NULL;
    }
    pthread_mutex_lock(&s->lk);
    while (!s->stop) {
        int want_halt = (s->cfg.faults & EF_GSUSB_SIM_F_STALL_IN) && !s->halted &&
                        s->in_sent >= s->cfg.stall_in_after;
        if (s->qn > 0 && inflight < GSS_AIO_DEPTH && !want_halt) {
            gss_item_t it = s->q[s->qhead];
            s->qhead = (s->qhead + 1) % s->cfg.rx_queue;
            s->qn--;
            pthread_cond_broadcast(&s->cv); /* room for an echo that waits */
            pthread_mutex_unlock(&s->lk);
            unsigned k = 0;
            while (busy[k])
                k++;
            size_t n = gss_in_encode(s, &it, buf[k]);
            if (gss_io_submit(ctx, &cb[k], s->ep1, 1, buf[k], n, k) == 0) {
                busy[k] = 1;
                inflight++;
            } else if (errno != EINTR) {
                /* Not enabled (the host went away): the frame is lost, as a transfer the
                 * host never takes would be. Never spin on it. */
                gss_sleep_until(gss_now_ns() + 10000000u);
            }
            pthread_mutex_lock(&s->lk);
            continue;
        }
        if (inflight == 0) {
            if (want_halt) {
                pthread_mutex_unlock(&s->lk);
                gss_halt_in(s);
                pthread_mutex_lock(&s->lk);
            } else {
                pthread_cond_wait(&s->cv, &s->lk);
            }
            continue;
        }
        /* Frames are queued on the endpoint: wait for one to complete; while there is room
         * for more, only briefly, so a frame arriving meanwhile is not held back. */
        pthread_mutex_unlock(&s->lk);
        struct io_event ev[GSS_AIO_DEPTH];
        long got =
            gss_io_wait(ctx, ev, inflight < GSS_AIO_DEPTH && !want_halt ? GSS_IN_POLL_NS : -1);
        for (long e = 0; e < got; e++) {
            unsigned k = (unsigned)ev[e].data;
            if (k < GSS_AIO_DEPTH && busy[k]) {
                busy[k] = 0;
                inflight--;
            }
        }
        pthread_mutex_lock(&s->lk);
    }
    pthread_mutex_unlock(&s->lk);
    gss_io_destroy(ctx);
    s->th_ep1.exited = 1;
    return NULL;
}

/* ---- frames from the host (ep2) ------------------------------------------------------ */

/* Hold the frame for its time on the bus at the channel's bitrate, as a controller does. */
static void gss_pace(struct ef_gsusb_sim_s *s, gss_chan_t *c, const ef_gsusb_frame_t *f,
                     uint32_t bitrate)
{
    if (!s->cfg.pace || bitrate == 0)
        return;
    ef_can_frame_t cf = {0};
    cf.id = f->can_id & EF_GSUSB_ID_MASK;
    cf.dlc = f->dlc;
    cf.flags = (uint8_t)(((f->can_id & EF_GSUSB_ID_EFF) ? EF_CAN_FLAG_EFF : 0) |
                         ((f->can_id & EF_GSUSB_ID_RTR) ? EF_CAN_FLAG_RTR : 0));
    uint64_t dur = (uint64_t)ef_can_frame_bits(&cf) * 1000000000u / bitrate;
    uint64_t now = gss_now_ns(), start = c->bus_free_ns;
    if (now > start + GSS_PACE_SLACK_NS)
        start = now; /* the bus was idle */
    c->bus_free_ns = start + dur;
    if (c->bus_free_ns > now + GSS_PACE_AHEAD_NS)
        gss_sleep_until(c->bus_free_ns);
}

/* Put a host frame on the CAN interface; retries while the kernel's queue is full. */
static int gss_send_can(struct ef_gsusb_sim_s *s, gss_chan_t *c, const ef_gsusb_frame_t *f)
{
    struct can_frame cf;
    memset(&cf, 0, sizeof cf);
    cf.can_id = f->can_id;
    cf.can_dlc = f->dlc;
    memcpy(cf.data, f->data, f->dlc);
    uint64_t give_up = gss_now_ns() + 1000000000u;
    for (;;) {
        if (write(c->fd, &cf, sizeof cf) == (ssize_t)sizeof cf)
            return 0;
        int e = errno;
        if ((e == ENOBUFS || e == EAGAIN || e == EINTR) && !s->stop && gss_now_ns() < give_up) {
            gss_sleep_until(gss_now_ns() + 200000u);
            continue;
        }
        return e;
    }
}

/* One transfer from ep2: decode, send, echo (ef_gsusb_sim.h, "Data"). */
static void gss_host_frame(struct ef_gsusb_sim_s *s, const uint8_t *buf, size_t n)
{
    ef_gsusb_frame_t f;
    ef_msg_t m = {{0}};
    int rc =
        (n == EF_GSUSB_FRAME_LEN || n == EF_GSUSB_FRAME_TS_LEN)
            ? ef_gsusb_frame_decode(buf, n, n == EF_GSUSB_FRAME_TS_LEN, 0, s->cfg.channels, &f, &m)
            : ef_fail(&m, EF_ERR_PROTO, "frame of %zu bytes (20 or 24)", n);
    if (rc == EF_OK && (f.can_id & EF_GSUSB_ID_ERR))
        rc = ef_fail(&m, EF_ERR_PROTO, "error frame from the host (can_id 0x%08x)", f.can_id);
    pthread_mutex_lock(&s->lk);
    if (rc != EF_OK) {
        if (gss_report(++s->st.bad_out))
            gss_say("host frame dropped: %s (%llu so far)", m.text,
                    (unsigned long long)s->st.bad_out);
        pthread_mutex_unlock(&s->lk);
        return;
    }
    gss_chan_t *c = &s->ch[f.channel];
    while (c->mode_pending && !s->stop) /* the MODE that starts it is being applied */
        pthread_cond_wait(&s->cv, &s->lk);
    uint32_t flags = c->flags, bitrate = c->bitrate;
    if (!c->started || (flags & EF_GSUSB_MODE_LISTEN_ONLY)) {
        if (gss_report(++s->st.dropped))
            gss_say("channel %u %s: host frame 0x%x dropped (%llu so far)", c->idx,
                    c->started ? "is listen-only" : "not started", f.can_id,
                    (unsigned long long)s->st.dropped);
        pthread_mutex_unlock(&s->lk);
        return;
    }
    pthread_mutex_unlock(&s->lk);

    gss_pace(s, c, &f, bitrate);
    if (!(flags & EF_GSUSB_MODE_LOOP_BACK)) {
        int e = gss_send_can(s, c, &f);
        if (e) {
            pthread_mutex_lock(&s->lk);
            if (gss_report(++s->st.tx_err))
                gss_say("channel %u: send 0x%x on %s: %s: not echoed", c->idx, f.can_id,
                        s->cfg.iface[c->idx < s->cfg.n_iface ? c->idx : 0], strerror(e));
            pthread_mutex_unlock(&s->lk);
            return;
        }
    }
    pthread_mutex_lock(&s->lk);
    s->st.tx++;
    if (!(s->cfg.faults & EF_GSUSB_SIM_F_NO_ECHO)) {
        ef_gsusb_frame_t echo = f;
        echo.flags = 0;
        /* An echo is never dropped (the host counts on it): wait for room. */
        while (!s->stop && c->started && !gss_push(s, c, &echo))
            pthread_cond_wait(&s->cv, &s->lk);
        if (c->started)
            s->st.echo++;
    }
    if ((flags & EF_GSUSB_MODE_LOOP_BACK) && c->started) {
        ef_gsusb_frame_t rx = f;
        gss_push_rx(s, c, &rx);
    }
    pthread_mutex_unlock(&s->lk);
}

/* ep2's thread: read the host's frames, GSS_AIO_DEPTH reads queued on the endpoint at once
 * (each completes with one transfer: a frame is a short packet), handled in the order they
 * complete, which is the order the host sent them. */
static void *gss_ep2_main(void *arg)
{
    struct ef_gsusb_sim_s *s = arg;
    uint8_t buf[GSS_AIO_DEPTH][GSS_HS_PACKET];
    struct iocb cb[GSS_AIO_DEPTH];
    int queued[GSS_AIO_DEPTH] = {0};
    aio_context_t ctx;
    if (gss_io_setup(&ctx) != 0) {
        gss_say("ep2: io_setup: %s", strerror(errno));
        s->th_ep2.exited = 1;
        return NULL;
    }
    while (!s->stop) {
        int failed = 0;
        for (unsigned k = 0; k < GSS_AIO_DEPTH && !s->stop && !failed; k++)
            if (!queued[k]) {
                /* Waits (interruptibly) while the host has not enabled the endpoint. */
                if (gss_io_submit(ctx, &cb[k], s->ep2, 0, buf[k], sizeof buf[k], k) == 0)
                    queued[k] = 1;
                else
                    failed = errno != EINTR;
            }
        struct io_event ev[GSS_AIO_DEPTH];
        long got = s->stop ? 0 : gss_io_wait(ctx, ev, -1);
        for (long e = 0; e < got; e++) {
            unsigned k = (unsigned)ev[e].data;
            if (k >= GSS_AIO_DEPTH)
                continue;
            queued[k] = 0;
            if (ev[e].res >= 0)
                gss_host_frame(s, buf[k], (size_t)ev[e].res);
            else
                failed = 1; /* ESHUTDOWN: the host deconfigured us */
        }
        /* Never spin on a persistent error: the next submit waits for the next ENABLE. */
        if (failed && !s->stop)
            gss_sleep_until(gss_now_ns() + 10000000u);
    }
    gss_io_destroy(ctx);
    s->th_ep2.exited = 1;
    return NULL;
}

/* ---- frames from the bus ------------------------------------------------------------- */

/* A channel's CAN thread: received frames go to the host while the channel is started. */
static void *gss_can_main(void *arg)
{
    gss_chan_t *c = arg;
    struct ef_gsusb_sim_s *s = c->s;
    while (!s->stop) {
        struct pollfd p = {c->fd, POLLIN, 0};
        if (poll(&p, 1, 200) <= 0)
            continue;
        struct can_frame cf;
        if (read(c->fd, &cf, sizeof cf) != (ssize_t)sizeof cf)
            continue;
        pthread_mutex_lock(&s->lk);
        /* Loop-back (internal, like bxCAN's) does not listen to the bus; bus errors
         * only reach a host that asked for them. */
        int want = s->enabled && c->started && !(c->flags & EF_GSUSB_MODE_LOOP_BACK);
        if ((cf.can_id & CAN_ERR_FLAG) && (cf.can_id & (CAN_ERR_PROT | CAN_ERR_BUSERROR)) &&
            !c->berr && !(c->flags & EF_GSUSB_MODE_BERR))
            want = 0;
        if (want) {
            ef_gsusb_frame_t f;
            memset(&f, 0, sizeof f);
            f.can_id = cf.can_id;
            f.dlc = cf.can_dlc > 8 ? 8 : cf.can_dlc;
            f.channel = (uint8_t)c->idx;
            memcpy(f.data, cf.data, f.dlc);
            gss_push_rx(s, c, &f);
        }
        pthread_mutex_unlock(&s->lk);
    }
    c->th.exited = 1;
    return NULL;
}

/* ---- ep0: the control requests -------------------------------------------------------- */

/* Stall the pending request: FunctionFS stalls it when ep0 is used the wrong way round
 * (read for an IN request, written for an OUT one). */
static void gss_stall(struct ef_gsusb_sim_s *s, const struct usb_ctrlrequest *r, const char *why)
{
    uint8_t b = 0;
    if (r->bRequestType & USB_DIR_IN) {
        if (read(s->ep0, &b, 1) >= 0 || errno != EL2HLT)
            gss_say("stall of %s: %s", ef_gsusb_req_name(r->bRequest), strerror(errno));
    } else if (write(s->ep0, &b, 1) >= 0 || errno != EL2HLT) {
        gss_say("stall of %s: %s", ef_gsusb_req_name(r->bRequest), strerror(errno));
    }
    pthread_mutex_lock(&s->lk);
    s->st.stalls++;
    pthread_mutex_unlock(&s->lk);
    if (s->cfg.verbose)
        gss_say("stall %s (bRequestType 0x%02x bRequest %u wValue %u wLength %u): %s",
                ef_gsusb_req_name(r->bRequest), r->bRequestType, r->bRequest, le16toh(r->wValue),
                le16toh(r->wLength), why);
}

/* Whether a timing is within BT_CONST's ranges (and the bitrate-max fault's). */
static const char *gss_bt_check(const struct ef_gsusb_sim_s *s, const ef_gsusb_bittiming_t *bt)
{
    const ef_gsusb_btconst_t *bc = &s->bc;
    uint32_t tseg1 = bt->prop_seg + bt->phase_seg1;
    if (tseg1 < bc->tseg1_min || tseg1 > bc->tseg1_max)
        return "prop_seg + phase_seg1 outside tseg1_min..tseg1_max";
    if (bt->phase_seg2 < bc->tseg2_min || bt->phase_seg2 > bc->tseg2_max)
        return "phase_seg2 outside tseg2_min..tseg2_max";
    if (bt->sjw < 1 || bt->sjw > bc->sjw_max)
        return "sjw outside 1..sjw_max";
    if (bt->brp < bc->brp_min || bt->brp > bc->brp_max || (bt->brp - bc->brp_min) % bc->brp_inc)
        return "brp outside brp_min..brp_max or off brp_inc";
    if ((s->cfg.faults & EF_GSUSB_SIM_F_BITRATE_MAX) &&
        ef_gsusb_bitrate(bc->fclk, bt) > s->cfg.bitrate_max)
        return "above the bitrate-max fault's limit";
    return NULL;
}

/* The data of an OUT request has arrived (and the host has been told it was accepted). */
static void gss_out(struct ef_gsusb_sim_s *s, unsigned req, gss_chan_t *c, const uint8_t *b,
                    size_t n)
{
    ef_msg_t m = {{0}};
    uint32_t v = 0, mode = 0, flags = 0;
    ef_gsusb_bittiming_t bt;
    const char *why;
    pthread_mutex_lock(&s->lk);
    switch (req) {
    case EF_GSUSB_BREQ_HOST_FORMAT:
        if (ef_gsusb_u32_decode(b, n, "HOST_FORMAT", &v, &m) == EF_OK &&
            v != EF_GSUSB_HOST_FORMAT_LE)
            gss_say("HOST_FORMAT 0x%08x ignored: only 0x%08x (little-endian) is spoken", v,
                    EF_GSUSB_HOST_FORMAT_LE);
        break;
    case EF_GSUSB_BREQ_BITTIMING:
        if (ef_gsusb_bittiming_decode(b, n, &bt, &m) != EF_OK)
            break;
        if ((why = gss_bt_check(s, &bt)) != NULL) {
            c->bt_refused = 1;
            gss_say("channel %u: BITTIMING refused (prop_seg %u phase_seg1 %u phase_seg2 %u "
                    "sjw %u brp %u: %u bit/s): %s; the next MODE is stalled",
                    c->idx, bt.prop_seg, bt.phase_seg1, bt.phase_seg2, bt.sjw, bt.brp,
                    ef_gsusb_bitrate(s->bc.fclk, &bt), why);
            break;
        }
        c->bt = bt;
        c->bitrate = ef_gsusb_bitrate(s->bc.fclk, &bt);
        c->bt_refused = 0;
        if (s->cfg.verbose)
            gss_say("channel %u: bit timing brp %u tseg1 %u tseg2 %u sjw %u: %u bit/s", c->idx,
                    bt.brp, bt.prop_seg + bt.phase_seg1, bt.phase_seg2, bt.sjw, c->bitrate);
        break;
    case EF_GSUSB_BREQ_MODE:
        if (ef_gsusb_mode_decode(b, n, &mode, &flags, &m) != EF_OK) {
            gss_say("channel %u: MODE refused: %s; channel stopped", c->idx, m.text);
            c->started = 0;
        } else if (mode == EF_GSUSB_MODE_START && (flags & ~GSS_MODE_OK)) {
            gss_say("channel %u: MODE start refused: flags 0x%x not supported (0x%x); channel "
                    "stopped",
                    c->idx, flags, flags & ~GSS_MODE_OK);
            c->started = 0;
        } else if (mode == EF_GSUSB_MODE_START) {
            c->started = 1;
            c->flags = flags;
            c->overflow = 0;
            if (s->cfg.verbose)
                gss_say("channel %u: started (flags 0x%x) at %u bit/s", c->idx, flags, c->bitrate);
        } else {
            c->started = 0;
            if (s->cfg.verbose)
                gss_say("channel %u: reset", c->idx);
        }
        pthread_cond_broadcast(&s->cv); /* an echo waiting for a stopped channel gives up */
        break;
    case EF_GSUSB_BREQ_BERR:
        if (ef_gsusb_u32_decode(b, n, "BERR", &v, &m) == EF_OK)
            c->berr = v != 0;
        break;
    case EF_GSUSB_BREQ_IDENTIFY:
        if (ef_gsusb_u32_decode(b, n, "IDENTIFY", &v, &m) == EF_OK && s->cfg.verbose)
            gss_say("channel %u: identify %s (LED blinks)", c->idx, v ? "on" : "off");
        break;
    default:
        break;
    }
    pthread_mutex_unlock(&s->lk);
}

/* The reply to an IN request into b (room for 64 KiB); returns its length. */
static size_t gss_in(struct ef_gsusb_sim_s *s, unsigned req, const gss_chan_t *c, uint8_t *b,
                     size_t wlength)
{
    size_t n = 0;
    pthread_mutex_lock(&s->lk);
    switch (req) {
    case EF_GSUSB_BREQ_DEVICE_CONFIG: {
        ef_gsusb_devcfg_t dc = {s->cfg.channels, GSS_SW_VERSION, GSS_HW_VERSION};
        n = ef_gsusb_devcfg_encode(&dc, b);
        /* long-reply: fill the whole wLength. The host only sees more than 12 bytes when
         * it asked for more: a control IN transfer ends at wLength (FunctionFS cuts the
         * write there), so a host asking for exactly 12 gets the normal reply. */
        if ((s->cfg.faults & EF_GSUSB_SIM_F_LONG_REPLY) && wlength > n) {
            memset(b + n, 0xA5, wlength - n);
            n = wlength;
        }
        break;
    }
    case EF_GSUSB_BREQ_BT_CONST:
        n = ef_gsusb_btconst_encode(&s->bc, b);
        if (s->cfg.faults & EF_GSUSB_SIM_F_SHORT_REPLY)
            n = 20; /* a short transfer: the host gets half a BT_CONST */
        break;
    case EF_GSUSB_BREQ_TIMESTAMP:
        ef_gsusb_put32(b, gss_ts(s));
        n = EF_GSUSB_U32_LEN;
        break;
    case EF_GSUSB_BREQ_GET_STATE: {
        ef_gsusb_state_t st = {c->bus_off   ? EF_GSUSB_STATE_BUS_OFF
                               : c->started ? EF_GSUSB_STATE_ACTIVE
                                            : EF_GSUSB_STATE_STOPPED,
                               0, c->bus_off ? 256u : 0u};
        n = ef_gsusb_state_encode(&st, b);
        break;
    }
    default:
        break;
    }
    pthread_mutex_unlock(&s->lk);
    return n;
}

/* One SETUP event: check the request, then answer, take its data, or stall it. */
static void gss_setup(struct ef_gsusb_sim_s *s, const struct usb_ctrlrequest *r, uint8_t *buf)
{
    unsigned req = r->bRequest, chan = le16toh(r->wValue);
    size_t len = le16toh(r->wLength), size = 0;
    int in = 0, per_chan = 1;
    pthread_mutex_lock(&s->lk);
    s->st.requests++;
    pthread_mutex_unlock(&s->lk);
    if (s->cfg.verbose)
        gss_say("request %s (bRequestType 0x%02x wValue %u wIndex %u wLength %zu)",
                ef_gsusb_req_name(req), r->bRequestType, chan, le16toh(r->wIndex), len);
    switch (req) {
    case EF_GSUSB_BREQ_HOST_FORMAT:
        size = EF_GSUSB_U32_LEN;
        per_chan = 0;
        break;
    case EF_GSUSB_BREQ_BITTIMING:
        size = EF_GSUSB_BITTIME_LEN;
        break;
    case EF_GSUSB_BREQ_MODE:
        size = EF_GSUSB_MODE_LEN;
        break;
    case EF_GSUSB_BREQ_BERR:
    case EF_GSUSB_BREQ_IDENTIFY:
        size = EF_GSUSB_U32_LEN;
        break;
    case EF_GSUSB_BREQ_BT_CONST:
        size = EF_GSUSB_BTCONST_LEN;
        in = 1;
        break;
    case EF_GSUSB_BREQ_DEVICE_CONFIG:
        size = EF_GSUSB_DEVCFG_LEN;
        in = 1;
        per_chan = 0;
        break;
    case EF_GSUSB_BREQ_TIMESTAMP:
        size = EF_GSUSB_U32_LEN;
        in = 1;
        per_chan = 0; /* one clock for the device */
        break;
    case EF_GSUSB_BREQ_GET_STATE:
        size = EF_GSUSB_STATE_LEN;
        in = 1;
        break;
    default:
        gss_stall(s, r, "unknown request");
        return;
    }
    if (r->bRequestType != (in ? EF_GSUSB_REQ_IN : EF_GSUSB_REQ_OUT)) {
        gss_stall(s, r, "wrong request type or direction");
        return;
    }
    if (per_chan && chan >= s->cfg.channels) {
        gss_stall(s, r, "no such channel");
        return;
    }
    if (in ? len < size : len != size) {
        gss_stall(s, r, "bad wLength");
        return;
    }
    gss_chan_t *c = &s->ch[per_chan ? chan : 0];
    if (req == EF_GSUSB_BREQ_MODE) {
        pthread_mutex_lock(&s->lk);
        int refused = c->bt_refused;
        pthread_mutex_unlock(&s->lk);
        if (refused) { /* the deferred refusal of a BITTIMING (ef_gsusb_sim.h) */
            gss_stall(s, r, "the channel's last BITTIMING was refused");
            return;
        }
    }
    if (in) {
        size_t n = gss_in(s, req, c, buf, len);
        if (write(s->ep0, buf, n) < 0)
            gss_say("reply to %s: %s", ef_gsusb_req_name(req), strerror(errno));
        return;
    }
    /* The host has its MODE answered as soon as ep0's data is read (FunctionFS ends the status
     * stage with it) and may send its first frame at once, before gss_out() has started the
     * channel: a real adapter starts it before the status stage. The ep2 thread holds a frame
     * for a stopped channel while a MODE is in progress (gss_host_frame()). */
    if (req == EF_GSUSB_BREQ_MODE) {
        pthread_mutex_lock(&s->lk);
        c->mode_pending = 1;
        pthread_mutex_unlock(&s->lk);
    }
    ssize_t got = read(s->ep0, buf, len);
    if (got != (ssize_t)len)
        gss_say("data of %s: %s", ef_gsusb_req_name(req), got < 0 ? strerror(errno) : "short");
    else
        gss_out(s, req, c, buf, len);
    if (req == EF_GSUSB_BREQ_MODE) {
        pthread_mutex_lock(&s->lk);
        c->mode_pending = 0;
        pthread_cond_broadcast(&s->cv);
        pthread_mutex_unlock(&s->lk);
    }
}

/* The host deconfigured the adapter: every channel stops and what was queued is lost. */
static void gss_disable(struct ef_gsusb_sim_s *s)
{
    pthread_mutex_lock(&s->lk);
    s->enabled = 0;
    s->qn = 0;
    for (unsigned k = 0; k < s->cfg.channels; k++)
        s->ch[k].started = 0;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->lk);
}

/* ENABLE: the host set our configuration. */
static void gss_enable(struct ef_gsusb_sim_s *s)
{
    struct usb_endpoint_descriptor d;
    uint16_t mps = GSS_HS_PACKET;
    memset(&d, 0, sizeof d);
    if (ioctl(s->ep1, FUNCTIONFS_ENDPOINT_DESC, &d) == 0 && le16toh(d.wMaxPacketSize))
        mps = le16toh(d.wMaxPacketSize);
    pthread_mutex_lock(&s->lk);
    s->in_packet = mps;
    s->enabled = 1;
    s->ever_enabled = 1;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->lk);
    if (s->cfg.verbose)
        gss_say("enabled (ep1 max packet %u)", mps);
}

/* ep0's thread: FunctionFS events. */
static void *gss_ep0_main(void *arg)
{
    static const char *const names[] = {"BIND",  "UNBIND",  "ENABLE", "DISABLE",
                                        "SETUP", "SUSPEND", "RESUME"};
    struct ef_gsusb_sim_s *s = arg;
    struct usb_functionfs_event ev[4];
    uint8_t *buf = malloc(65536);
    while (buf && !s->stop) {
        ssize_t n = read(s->ep0, ev, sizeof ev);
        if (n < 0) {
            /* EINTR: stop; EIDRM: the host gave up on a request and sent the next. */
            if (errno != EINTR && errno != EIDRM && !s->stop)
                gss_sleep_until(gss_now_ns() + 10000000u);
            continue;
        }
        for (size_t i = 0; i < (size_t)n / sizeof ev[0]; i++) {
            if (s->cfg.verbose && ev[i].type < 7 && ev[i].type != FUNCTIONFS_SETUP)
                gss_say("event %s", names[ev[i].type]);
            switch (ev[i].type) {
            case FUNCTIONFS_ENABLE:
                gss_enable(s);
                break;
            case FUNCTIONFS_DISABLE:
            case FUNCTIONFS_UNBIND:
                gss_disable(s);
                break;
            case FUNCTIONFS_SETUP:
                if (s->cfg.faults & EF_GSUSB_SIM_F_NO_ANSWER) {
                    /* The request stays pending; the host's transfer times out. Reading
                     * ep0 again would answer it (a stall or its data), so ep0 is left
                     * alone from here on. */
                    gss_say("fault no-answer: %s left unanswered; ep0 is not serviced any "
                            "more",
                            ef_gsusb_req_name(ev[i].u.setup.bRequest));
                    pthread_mutex_lock(&s->lk);
                    while (!s->stop)
                        pthread_cond_wait(&s->cv, &s->lk);
                    pthread_mutex_unlock(&s->lk);
                    break;
                }
                gss_setup(s, &ev[i].u.setup, buf);
                break;
            default:
                break;
            }
        }
    }
    free(buf);
    s->th_ep0.exited = 1;
    return NULL;
}

/* ---- life cycle ----------------------------------------------------------------------- */

/* SIGUSR1 interrupts a thread's blocked read or write; nothing else to do. */
static void gss_on_usr1(int sig)
{
    (void)sig;
}

/* Start a thread with every signal blocked but SIGUSR1 (the process's handlers run in the
 * caller's threads, and ef_gsusb_sim_stop() reaches each thread with SIGUSR1). */
static int gss_spawn(gss_thread_t *t, void *(*fn)(void *), void *arg, ef_msg_t *m)
{
    sigset_t all, old;
    sigfillset(&all);
    sigdelset(&all, SIGUSR1);
    pthread_sigmask(SIG_SETMASK, &all, &old);
    t->exited = 0;
    int e = pthread_create(&t->id, NULL, fn, arg);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (e)
        return ef_fail(m, EF_ERR_NOMEM, "pthread_create: %s", strerror(e));
    t->running = 1;
    return EF_OK;
}

/* Interrupt a thread until it has left its loop, then join it. */
static void gss_reap(gss_thread_t *t)
{
    if (!t->running)
        return;
    while (!t->exited) {
        pthread_kill(t->id, SIGUSR1);
        gss_sleep_until(gss_now_ns() + 5000000u);
    }
    pthread_join(t->id, NULL);
    t->running = 0;
}

/* Open channel c's raw CAN socket on its interface (every error class subscribed: the
 * CAN thread decides what reaches the host). */
static int gss_open_can(struct ef_gsusb_sim_s *s, gss_chan_t *c, ef_msg_t *m)
{
    const char *ifname = s->cfg.iface[c->idx < s->cfg.n_iface ? c->idx : 0];
    struct sockaddr_can a;
    can_err_mask_t em = CAN_ERR_MASK;
    unsigned idx = if_nametoindex(ifname);
    if (!idx)
        return ef_fail(m, EF_ERR_IO, "CAN interface %s: %s", ifname, strerror(errno));
    c->fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (c->fd < 0)
        return ef_fail(m, EF_ERR_IO, "socket(PF_CAN): %s", strerror(errno));
    setsockopt(c->fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &em, sizeof em);
    memset(&a, 0, sizeof a);
    a.can_family = AF_CAN;
    a.can_ifindex = (int)idx;
    if (bind(c->fd, (struct sockaddr *)&a, sizeof a) != 0)
        return ef_fail(m, EF_ERR_IO, "bind to %s: %s", ifname, strerror(errno));
    return EF_OK;
}

void ef_gsusb_sim_cfg_default(ef_gsusb_sim_cfg_t *c)
{
    if (!c)
        return;
    memset(c, 0, sizeof *c);
    c->name = "ef_gsusb";
    c->serial = "EF0000000001";
    c->configfs = "/sys/kernel/config";
    c->vid = 0x1d50;
    c->pid = 0x606f;
    c->bcd_device = 0x0100;
    c->channels = 1;
    c->fclk = 48000000u;
    c->pace = 1;
    c->rx_queue = 64;
    c->stall_in_after = 10;
}

void ef_gsusb_sim_btconst(const ef_gsusb_sim_cfg_t *c, ef_gsusb_btconst_t *bc)
{
    memset(bc, 0, sizeof *bc);
    bc->feature = GSS_FEATURES;
    bc->fclk = c ? c->fclk : 48000000u;
    bc->tseg1_min = 1;
    bc->tseg1_max = 16;
    bc->tseg2_min = 1;
    bc->tseg2_max = 8;
    bc->sjw_max = 4;
    bc->brp_min = 1;
    bc->brp_max = 1024;
    bc->brp_inc = 1;
}

int ef_gsusb_sim_fault(ef_gsusb_sim_cfg_t *c, const char *kind, ef_msg_t *m)
{
    static const struct {
        const char *name;
        unsigned bit;
    } plain[] = {
        {"short-reply", EF_GSUSB_SIM_F_SHORT_REPLY}, {"long-reply", EF_GSUSB_SIM_F_LONG_REPLY},
        {"bad-frame", EF_GSUSB_SIM_F_BAD_FRAME},     {"bad-channel", EF_GSUSB_SIM_F_BAD_CHANNEL},
        {"no-echo", EF_GSUSB_SIM_F_NO_ECHO},         {"no-answer", EF_GSUSB_SIM_F_NO_ANSWER},
        {"bus-off", EF_GSUSB_SIM_F_BUS_OFF},         {"overflow", EF_GSUSB_SIM_F_OVERFLOW}};
    if (!c || !kind)
        return ef_fail(m, EF_ERR_ARG, "fault: NULL");
    for (size_t i = 0; i < sizeof plain / sizeof plain[0]; i++) {
        if (!strcmp(kind, plain[i].name)) {
            c->faults |= plain[i].bit;
            return EF_OK;
        }
    }
    const char *eq = strchr(kind, '=');
    size_t klen = eq ? (size_t)(eq - kind) : strlen(kind);
    char *end = NULL;
    unsigned long long v = 0;
    if (eq) {
        errno = 0;
        v = strtoull(eq + 1, &end, 10);
        if (!eq[1] || *end || errno || eq[1] == '-')
            return ef_fail(m, EF_ERR_ARG, "fault %s: '%s' is not a whole number", kind, eq + 1);
    }
    if (klen == 8 && !strncmp(kind, "stall-in", 8)) {
        if (eq && v > 1000000000u)
            return ef_fail(m, EF_ERR_ARG, "fault stall-in=N: N 0..1000000000");
        c->faults |= EF_GSUSB_SIM_F_STALL_IN;
        if (eq)
            c->stall_in_after = (uint32_t)v;
        return EF_OK;
    }
    if (klen == 11 && !strncmp(kind, "bitrate-max", 11)) {
        if (!eq || v < 1 || v > 1000000u)
            return ef_fail(m, EF_ERR_ARG, "fault bitrate-max=N: N in bit/s, 1..1000000");
        c->faults |= EF_GSUSB_SIM_F_BITRATE_MAX;
        c->bitrate_max = (uint32_t)v;
        return EF_OK;
    }
    return ef_fail(m, EF_ERR_ARG,
                   "unknown fault '%s' (short-reply, long-reply, bad-frame, bad-channel, "
                   "stall-in[=N], no-echo, no-answer, bitrate-max=N, bus-off, overflow)",
                   kind);
}

/* Whether a gadget name is safe as a configfs directory and FunctionFS instance name. */
static int gss_name_ok(const char *n)
{
    size_t len = strlen(n);
    if (len == 0 || len > 32)
        return 0;
    for (size_t i = 0; i < len; i++) {
        char ch = n[i];
        if (!((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
              ch == '_' || ch == '-'))
            return 0;
    }
    return 1;
}

int ef_gsusb_sim_start(const ef_gsusb_sim_cfg_t *cfg, ef_gsusb_sim_t **out, ef_msg_t *m)
{
    if (!cfg || !out)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: NULL");
    *out = NULL;
    if (cfg->n_iface < 1 || !cfg->iface[0])
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: no CAN interface");
    if (cfg->channels < 1 || cfg->channels > EF_GSUSB_MAX_CHANNELS)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: channels %u: 1..%u", cfg->channels,
                       EF_GSUSB_MAX_CHANNELS);
    if (cfg->n_iface > cfg->channels)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: %u interfaces for %u channels", cfg->n_iface,
                       cfg->channels);
    if (cfg->rx_queue < 2 || cfg->rx_queue > 1024)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: rx_queue %u: 2..1024", cfg->rx_queue);
    if (!cfg->name || !gss_name_ok(cfg->name) || !cfg->serial || !cfg->configfs || cfg->fclk == 0)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: name '%s': 1..32 of [A-Za-z0-9_-]",
                       cfg->name ? cfg->name : "(null)");
    struct ef_gsusb_sim_s *s = calloc(1, sizeof *s);
    if (!s)
        return ef_fail(m, EF_ERR_NOMEM, "gs_usb sim: out of memory");
    s->cfg = *cfg;
    s->q = calloc(cfg->rx_queue, sizeof *s->q);
    if (!s->q) {
        free(s);
        return ef_fail(m, EF_ERR_NOMEM, "gs_usb sim: out of memory");
    }
    pthread_mutex_init(&s->lk, NULL);
    pthread_cond_init(&s->cv, NULL);
    s->ep0 = s->ep1 = s->ep2 = -1;
    s->in_packet = GSS_HS_PACKET;
    s->t0_ns = gss_now_ns();
    snprintf(s->name, sizeof s->name, "%s", cfg->name);
    snprintf(s->gadget, sizeof s->gadget, "%s/usb_gadget/%s", cfg->configfs, s->name);
    if (cfg->ffs_dir)
        snprintf(s->ffs, sizeof s->ffs, "%s", cfg->ffs_dir);
    else
        snprintf(s->ffs, sizeof s->ffs, "/dev/ffs-%s", s->name);
    ef_gsusb_sim_btconst(cfg, &s->bc);
    for (unsigned k = 0; k < EF_GSUSB_MAX_CHANNELS; k++) {
        s->ch[k].s = s;
        s->ch[k].idx = k;
        s->ch[k].fd = -1;
        s->ch[k].bitrate = GSS_DEFAULT_BITRATE;
    }
    *out = s;

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = gss_on_usr1; /* no SA_RESTART: the blocked call must return EINTR */
    sigaction(SIGUSR1, &sa, NULL);

    char path[512];
    struct stat sb;
    int rc = EF_OK;
    snprintf(path, sizeof path, "%s/usb_gadget", cfg->configfs);
    if (stat(path, &sb) != 0)
        rc = ef_fail(m, EF_ERR_IO, "%s: %s (mount configfs there; the kernel needs USB_CONFIGFS)",
                     path, strerror(errno));
    for (unsigned k = 0; rc == EF_OK && k < cfg->channels; k++)
        rc = gss_open_can(s, &s->ch[k], m);
    if (rc == EF_OK)
        rc = gss_pick_udc(s, m);
    if (rc == EF_OK) {
        gss_unmake(s); /* what a killed run left behind */
        rc = gss_make(s, m);
    }
    if (rc == EF_OK)
        rc = gss_spawn(&s->th_ep0, gss_ep0_main, s, m);
    if (rc == EF_OK)
        rc = gss_spawn(&s->th_ep1, gss_ep1_main, s, m);
    if (rc == EF_OK)
        rc = gss_spawn(&s->th_ep2, gss_ep2_main, s, m);
    for (unsigned k = 0; rc == EF_OK && k < cfg->channels; k++)
        rc = gss_spawn(&s->ch[k].th, gss_can_main, &s->ch[k], m);
    if (rc == EF_OK) {
        ef_msg_t why = {{0}};
        rc = gss_attr(s, "UDC", s->udc, &why);
        if (rc != EF_OK)
            ef_fail(m, rc, "bind to UDC %s (busy with another gadget?): %s", s->udc, why.text);
        else
            s->bound = 1;
    }
    if (rc != EF_OK) {
        ef_gsusb_sim_stop(s);
        *out = NULL;
        return rc;
    }
    if (cfg->verbose)
        gss_say("gadget %s bound to %s (FunctionFS at %s)", s->gadget, s->udc, s->ffs);
    return EF_OK;
}

int ef_gsusb_sim_wait_ready(ef_gsusb_sim_t *s, long timeout_ms)
{
    if (!s)
        return EF_ERR_ARG;
    uint64_t end = gss_now_ns() + (uint64_t)(timeout_ms < 0 ? 0 : timeout_ms) * 1000000u;
    int rc = EF_ERR_AGAIN;
    pthread_mutex_lock(&s->lk);
    for (;;) {
        if (s->ever_enabled) {
            rc = EF_OK;
            break;
        }
        if ((s->cfg.stop && *s->cfg.stop) || (timeout_ms >= 0 && gss_now_ns() >= end))
            break;
        /* Short waits: *stop is set by a signal handler, which cannot signal cv. */
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 50000000;
        if (ts.tv_nsec >= 1000000000) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000;
        }
        pthread_cond_timedwait(&s->cv, &s->lk, &ts);
    }
    pthread_mutex_unlock(&s->lk);
    return rc;
}

const char *ef_gsusb_sim_udc(const ef_gsusb_sim_t *s)
{
    return s ? s->udc : "";
}

void ef_gsusb_sim_stats(ef_gsusb_sim_t *s, ef_gsusb_sim_stats_t *st)
{
    if (!s || !st)
        return;
    pthread_mutex_lock(&s->lk);
    *st = s->st;
    pthread_mutex_unlock(&s->lk);
}

void ef_gsusb_sim_stop(ef_gsusb_sim_t *s)
{
    if (!s)
        return;
    pthread_mutex_lock(&s->lk);
    s->stop = 1;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->lk);
    /* Unbind first: the host sees the adapter go away, FunctionFS ends pending I/O. */
    if (s->bound) {
        char path[512];
        snprintf(path, sizeof path, "%s/UDC", s->gadget);
        int fd = open(path, O_WRONLY | O_CLOEXEC);
        if (fd < 0 || write(fd, "\n", 1) != 1)
            gss_say("unbind %s: %s", path, strerror(errno));
        if (fd >= 0)
            close(fd);
        s->bound = 0;
    }
    gss_reap(&s->th_ep0);
    gss_reap(&s->th_ep1);
    gss_reap(&s->th_ep2);
    for (unsigned k = 0; k < EF_GSUSB_MAX_CHANNELS; k++)
        gss_reap(&s->ch[k].th);
    if (s->ep2 >= 0)
        close(s->ep2);
    if (s->ep1 >= 0)
        close(s->ep1);
    if (s->ep0 >= 0)
        close(s->ep0);
    s->ep0 = s->ep1 = s->ep2 = -1;
    gss_unmake(s);
    for (unsigned k = 0; k < EF_GSUSB_MAX_CHANNELS; k++)
        if (s->ch[k].fd >= 0)
            close(s->ch[k].fd);
    pthread_cond_destroy(&s->cv);
    pthread_mutex_destroy(&s->lk);
    free(s->q);
    free(s);
}

int ef_gsusb_sim_run(const ef_gsusb_sim_cfg_t *c, ef_msg_t *m)
{
    if (!c || !c->stop)
        return ef_fail(m, EF_ERR_ARG, "gs_usb sim: no stop flag");
    ef_gsusb_sim_t *s;
    int rc = ef_gsusb_sim_start(c, &s, m);
    if (rc != EF_OK)
        return rc;
    if (ef_gsusb_sim_wait_ready(s, -1) == EF_OK) {
        printf("ready gs_usb serial=%s udc=%s\n", c->serial, s->udc);
        fflush(stdout);
    }
    while (!*c->stop)
        gss_sleep_until(gss_now_ns() + 50000000u);
    ef_gsusb_sim_stats_t st;
    memset(&st, 0, sizeof st);
    ef_gsusb_sim_stats(s, &st);
    if (c->verbose)
        gss_say("requests %llu (stalled %llu), tx %llu, echo %llu, rx %llu, rx overflow %llu, "
                "bad %llu, dropped %llu, tx errors %llu",
                (unsigned long long)st.requests, (unsigned long long)st.stalls,
                (unsigned long long)st.tx, (unsigned long long)st.echo, (unsigned long long)st.rx,
                (unsigned long long)st.rx_overflow, (unsigned long long)st.bad_out,
                (unsigned long long)st.dropped, (unsigned long long)st.tx_err);
    ef_gsusb_sim_stop(s);
    return EF_OK;
}
