/* SPDX-License-Identifier: Apache-2.0 */
/* SocketCAN transport (ef_sockcan) tests.
 *
 *   test_sockcan offline WORKDIR   on any host: argument checks, open failure text, candump
 *                                  log format, frame bit counts (no CAN needed)
 *   test_sockcan hil WORKDIR       inside User-Mode Linux with vcan0 up (tests/hil/sockcan.sh):
 *                                  filters, candump log read back by can-utils, error frames
 *                                  (bus-off, error-passive, restart), ENOBUFS back-off and
 *                                  backlog, interface down
 *
 * The hil mode runs as root in the guest and drives the interface and its queueing discipline
 * with ip(8) and tc(8): a "plug" qdisc with a small byte limit holds frames and makes the
 * kernel answer ENOBUFS, like a controller whose TX mailboxes and txqueue are full. */
#include <errno.h>
#include <stdint.h>
#include <string.h>
#include <sys/socket.h>
#include <net/if.h>
#include <time.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>

#include "ef_test.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/host/can/ef_sockcan.h"
#include "evenfeed/host/can/ef_canif.h"
#include "evenfeed/host/can/ef_canmem.h"
#include "evenfeed/host/can/ef_canpump.h"

#define IF "vcan0"

static char workdir[400];

/* Path of a file in the work directory. */
static const char *wpath(char *buf, size_t n, const char *name)
{
    snprintf(buf, n, "%s/%s", workdir, name);
    return buf;
}

/* Run a shell command, reporting it; returns its exit status. */
static int sh(const char *cmd)
{
    int rc = system(cmd);
    if (rc != 0)
        fprintf(stderr, "command '%s': status %d\n", cmd, rc);
    return rc;
}

/* A data frame with a 16-bit sequence number in its first two bytes. */
static ef_can_frame_t seq_frame(uint32_t id, unsigned seq)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = 8;
    f.data[0] = (uint8_t)(seq >> 8);
    f.data[1] = (uint8_t)seq;
    for (int i = 2; i < 8; i++)
        f.data[i] = (uint8_t)(seq * 7u + (unsigned)i);
    return f;
}

/* Sequence number carried by seq_frame(). */
static unsigned seq_of(const ef_can_frame_t *f)
{
    return ((unsigned)f->data[0] << 8) | f->data[1];
}

/* Sleep for some microseconds. */
static void usleep_(long us)
{
    struct timespec ts = {us / 1000000, (us % 1000000) * 1000};
    nanosleep(&ts, NULL);
}

/* Count lines of a file that contain a string. */
static int count_lines(const char *path, const char *needle)
{
    size_t len;
    char *b = ef_t_slurp(path, &len);
    int n = 0;
    if (!b)
        return -1;
    for (char *line = strtok(b, "\n"); line; line = strtok(NULL, "\n"))
        if (strstr(line, needle))
            n++;
    free(b);
    return n;
}

/* ------------------------------------------------------------------ offline */

/* Argument checks and open failures: codes and message texts. */
static void t_open_errors(void)
{
    ef_sockcan_t s;
    ef_msg_t m = {{0}};
    ef_sockcan_filter_t flt[EF_SOCKCAN_MAX_FILTERS + 1];
    memset(flt, 0, sizeof flt);

    EF_CHECK_EQ(ef_sockcan_open(NULL, IF, NULL, 0, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_open(&s, NULL, NULL, 0, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(s.fd, -1);
    EF_CHECK_EQ(ef_sockcan_open(&s, "", NULL, 0, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_open(&s, "averyveryverylongname0", NULL, 0, NULL, &m), EF_ERR_ARG);
    EF_CHECK(strstr(m.text, "averyveryverylong") != NULL);
    EF_CHECK_EQ(ef_sockcan_open(&s, IF, flt, EF_SOCKCAN_MAX_FILTERS + 1, NULL, &m), EF_ERR_ARG);
    EF_CHECK(strstr(m.text, IF) != NULL);
    EF_CHECK_EQ(ef_sockcan_open(&s, IF, NULL, 2, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_open(&s, IF, flt, -1, NULL, &m), EF_ERR_ARG);

    /* No such interface (or, on a kernel without CAN, no PF_CAN): EF_ERR_IO naming it. */
    EF_CHECK_EQ(ef_sockcan_open(&s, "nosuchcan7", NULL, 0, NULL, &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "nosuchcan7") != NULL);
    fprintf(stderr, "  open nosuchcan7: %s\n", m.text);
    EF_CHECK_EQ(s.fd, -1);
    EF_CHECK(s.log == NULL);
    ef_sockcan_close(&s); /* closed: harmless */
    ef_sockcan_close(&s);
    ef_sockcan_close(NULL);

    /* Calls on a socket that is not open. */
    ef_can_frame_t f = seq_frame(0x100, 1);
    EF_CHECK_EQ(ef_sockcan_send(&s, &f), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_recv(&s, &f, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_flush(&s), EF_ERR_ARG);
    EF_CHECK_EQ(ef_sockcan_send(NULL, &f), EF_ERR_ARG);
}

/* The candump log line format, byte for byte after the timestamp. */
static void t_log_format(void)
{
    char path[512], exp[64];
    FILE *log = fopen(wpath(path, sizeof path, "format.log"), "w");
    EF_CHECK(log != NULL);
    if (!log)
        return;
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = 0x123;
    f.dlc = 4;
    memcpy(f.data, "\xDE\xAD\xBE\xEF", 4);
    ef_sockcan_log_frame(log, IF, &f); /* 123#DEADBEEF */
    f.flags = EF_CAN_FLAG_RTR;
    f.dlc = 0;
    ef_sockcan_log_frame(log, IF, &f); /* 123#R */
    f.dlc = 4;
    ef_sockcan_log_frame(log, IF, &f); /* 123#R4 */
    f.flags = EF_CAN_FLAG_EFF;
    f.id = 0x1ABCDE;
    f.dlc = 2;
    f.data[0] = 0x01;
    f.data[1] = 0xa0;
    ef_sockcan_log_frame(log, IF, &f); /* 001ABCDE#01A0 */
    f.flags = 0;
    f.id = 0x7;
    f.dlc = 0;
    ef_sockcan_log_frame(log, IF, &f); /* 007# */
    ef_sockcan_log_frame(NULL, IF, &f);
    ef_sockcan_log_frame(log, IF, NULL);
    fclose(log);

    const char *want[] = {"123#DEADBEEF", "123#R", "123#R4", "001ABCDE#01A0", "007#"};
    size_t len;
    char *b = ef_t_slurp(path, &len);
    EF_CHECK(b != NULL);
    if (!b)
        return;
    time_t now = time(NULL);
    int i = 0;
    for (char *line = strtok(b, "\n"); line; line = strtok(NULL, "\n"), i++) {
        long long sec = 0;
        long usec = -1;
        int n = 0;
        char rest[64] = "";
        EF_CHECK(line[0] == '(' && line[11] == '.' && line[18] == ')');
        EF_CHECK_EQ(sscanf(line, "(%lld.%6ld) %n", &sec, &usec, &n), 2);
        EF_CHECK(sec > now - 5 && sec <= now + 1);
        EF_CHECK(usec >= 0 && usec < 1000000);
        snprintf(rest, sizeof rest, "%s", line + n);
        if (i < 5) {
            snprintf(exp, sizeof exp, IF " %s", want[i]);
            if (strcmp(rest, exp) != 0)
                fprintf(stderr, "log line %d: '%s', expected '%s'\n", i, rest, exp);
            EF_CHECK(strcmp(rest, exp) == 0);
        }
    }
    EF_CHECK_EQ(i, 5);
    free(b);
}

/* Bus bits per frame (the formula in ef_can.h). */
static void t_frame_bits(void)
{
    ef_can_frame_t f;
    memset(&f, 0, sizeof f);
    EF_CHECK_EQ(ef_can_frame_bits(&f), 55);
    f.dlc = 8;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 135);
    f.dlc = 1;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 47 + 8 + (34 + 8 - 1) / 4);
    f.dlc = 15; /* counts as 8 */
    EF_CHECK_EQ(ef_can_frame_bits(&f), 135);
    f.flags = EF_CAN_FLAG_EFF;
    f.dlc = 0;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 67 + (54 - 1) / 4);
    f.dlc = 8;
    EF_CHECK_EQ(ef_can_frame_bits(&f), 67 + 64 + (54 + 64 - 1) / 4);

    uint32_t a = ef_sockcan_now_us();
    usleep_(2000);
    uint32_t b = ef_sockcan_now_us();
    EF_CHECK(ef_time_reached(b, a + 1500));
}

/* ------------------------------------------------------------------ in the guest */

/* A plain raw socket on vcan0 that injects frames (error frames included). */
static int raw_injector(void)
{
    struct sockaddr_can a;
    int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    memset(&a, 0, sizeof a);
    a.can_family = AF_CAN;
    a.can_ifindex = (int)if_nametoindex(IF);
    if (fd < 0 || bind(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        fprintf(stderr, "injector socket: %s\n", strerror(errno));
        if (fd >= 0)
            close(fd);
        return -1;
    }
    return fd;
}

/* Send one raw frame from the injector. */
static int inject(int fd, uint32_t can_id, const uint8_t data[8])
{
    struct can_frame cf;
    memset(&cf, 0, sizeof cf);
    cf.can_id = can_id;
    cf.can_dlc = 8;
    if (data)
        memcpy(cf.data, data, 8);
    return write(fd, &cf, sizeof cf) == (ssize_t)sizeof cf ? 0 : -1;
}

/* Open two sockets on vcan0: a sender and a receiver (with optional filters and logs). */
static int open_pair(ef_sockcan_t *tx, ef_sockcan_t *rx, const ef_sockcan_filter_t *flt, int n,
                     const char *txlog, const char *rxlog)
{
    ef_msg_t m;
    int rc = ef_sockcan_open(tx, IF, NULL, 0, txlog, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "open tx: %s\n", m.text);
        return rc;
    }
    rc = ef_sockcan_open(rx, IF, flt, n, rxlog, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "open rx: %s\n", m.text);
        ef_sockcan_close(tx);
    }
    return rc;
}

/* Open errors that need a CAN kernel: missing interface, unwritable log. */
static void t_hil_open(void)
{
    ef_sockcan_t s;
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_sockcan_open(&s, "nosuchcan7", NULL, 0, NULL, &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "nosuchcan7") && strstr(m.text, "no such interface"));
    fprintf(stderr, "  %s\n", m.text);
    EF_CHECK_EQ(ef_sockcan_open(&s, "lo", NULL, 0, NULL, &m), EF_ERR_IO); /* not CAN */
    EF_CHECK(strstr(m.text, "lo") != NULL);
    fprintf(stderr, "  %s\n", m.text);
    EF_CHECK_EQ(ef_sockcan_open(&s, IF, NULL, 0, "/nonexistent-dir/x.log", &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "candump log") && strstr(m.text, IF));
    EF_CHECK_EQ(s.fd, -1);
    EF_CHECK_EQ(ef_sockcan_open(&s, IF, NULL, 0, NULL, &m), EF_OK);
    EF_CHECK(s.fd >= 0);
    ef_sockcan_close(&s);
    EF_CHECK_EQ(s.fd, -1);
}

/* Send / receive with filters, RTR and extended frames; logs read back by can-utils. */
static void t_hil_filters_and_log(void)
{
    char txlog[512], rxlog[512], cmd[1400], asc[512];
    ef_sockcan_filter_t flt[2] = {{0x123, 0x7FF | CAN_EFF_FLAG}, {0x200, 0x700}};
    ef_sockcan_t tx, rx, all;
    ef_can_frame_t f, g;
    ef_msg_t m;

    if (open_pair(&tx, &rx, flt, 2, wpath(txlog, sizeof txlog, "tx.log"),
                  wpath(rxlog, sizeof rxlog, "rx.log")) != EF_OK)
        return;
    EF_CHECK_EQ(ef_sockcan_open(&all, IF, NULL, 0, NULL, &m), EF_OK);
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 0), EF_ERR_AGAIN);

    ef_can_frame_t sent[6];
    sent[0] = seq_frame(0x123, 1); /* passes filter 0 */
    sent[1] = seq_frame(0x124, 2); /* filtered out */
    sent[2] = seq_frame(0x2AB, 3); /* passes filter 1 */
    sent[3] = seq_frame(0x123, 4); /* extended 0x123: filter 0 wants base frames only */
    sent[3].flags = EF_CAN_FLAG_EFF;
    sent[4] = seq_frame(0x123, 5); /* RTR, dlc 2: passes filter 0 */
    sent[4].flags = EF_CAN_FLAG_RTR;
    sent[4].dlc = 2;
    sent[5] = seq_frame(0x1ABCDEF, 6); /* extended, filtered out */
    sent[5].flags = EF_CAN_FLAG_EFF;
    sent[5].dlc = 3;
    uint64_t bits = 0;
    for (int i = 0; i < 6; i++) {
        EF_CHECK_EQ(ef_sockcan_send(&tx, &sent[i]), EF_OK);
        bits += ef_can_frame_bits(&sent[i]);
    }
    EF_CHECK_EQ(tx.tx, 6);
    EF_CHECK_EQ(tx.tx_bits, bits);
    EF_CHECK_EQ(tx.bl_count, 0);
    /* own frames are not received */
    EF_CHECK_EQ(ef_sockcan_recv(&tx, &g, 20000), EF_ERR_AGAIN);

    const int want[3] = {0, 2, 4};
    for (int k = 0; k < 3; k++) {
        memset(&g, 0xAA, sizeof g);
        int rc = ef_sockcan_recv(&rx, &g, 1000000);
        EF_CHECK_EQ(rc, EF_OK);
        if (rc != EF_OK)
            break;
        f = sent[want[k]];
        EF_CHECK_EQ(g.id, f.id);
        EF_CHECK_EQ(g.flags, f.flags);
        EF_CHECK_EQ(g.dlc, f.dlc);
        if (!(f.flags & EF_CAN_FLAG_RTR))
            EF_CHECK(memcmp(g.data, f.data, f.dlc) == 0);
    }
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 50000), EF_ERR_AGAIN); /* 0x124, EFF: filtered */
    EF_CHECK_EQ(rx.rx, 3);
    /* the unfiltered socket sees all six, extended ids intact */
    int n_all = 0;
    while (ef_sockcan_recv(&all, &g, 200000) == EF_OK) {
        if (n_all < 6) {
            EF_CHECK_EQ(g.id, sent[n_all].id);
            EF_CHECK_EQ(g.flags, sent[n_all].flags);
        }
        n_all++;
    }
    EF_CHECK_EQ(n_all, 6);
    ef_sockcan_close(&all);
    ef_sockcan_close(&tx);
    ef_sockcan_close(&rx);

    /* the logs: TX has all six lines, RX the three received */
    EF_CHECK_EQ(count_lines(txlog, ") " IF " "), 6);
    EF_CHECK_EQ(count_lines(rxlog, ") " IF " "), 3);
    EF_CHECK_EQ(count_lines(txlog, IF " 123#0001"), 1);
    EF_CHECK_EQ(count_lines(txlog, IF " 00000123#0004"), 1);
    EF_CHECK_EQ(count_lines(txlog, IF " 123#R2"), 1);
    EF_CHECK_EQ(count_lines(txlog, IF " 01ABCDEF#00062C"), 1);
    EF_CHECK_EQ(count_lines(rxlog, IF " 2AB#0003"), 1);

    /* can-utils read the log back: log2asc converts it, canplayer replays it onto vcan0 */
    snprintf(cmd, sizeof cmd, "log2asc -I '%s' " IF " > '%s'", txlog,
             wpath(asc, sizeof asc, "tx.asc"));
    EF_CHECK_EQ(sh(cmd), 0);
    EF_CHECK(count_lines(asc, "1ABCDEFx") == 1); /* ASC marks extended ids with x */
    EF_CHECK_EQ(ef_sockcan_open(&all, IF, NULL, 0, NULL, &m), EF_OK);
    snprintf(cmd, sizeof cmd, "canplayer -t -I '%s'", txlog);
    EF_CHECK_EQ(sh(cmd), 0);
    n_all = 0;
    while (ef_sockcan_recv(&all, &g, 300000) == EF_OK) {
        if (n_all < 6) {
            EF_CHECK_EQ(g.id, sent[n_all].id);
            EF_CHECK_EQ(g.flags, sent[n_all].flags);
            EF_CHECK_EQ(g.dlc, sent[n_all].dlc);
            if (!(g.flags & EF_CAN_FLAG_RTR))
                EF_CHECK(memcmp(g.data, sent[n_all].data, g.dlc) == 0);
        }
        n_all++;
    }
    EF_CHECK_EQ(n_all, 6); /* the replay carries the same six frames */
    ef_sockcan_close(&all);
}

/* Error frames injected on vcan0 by another raw socket: bus-off, passive, warning, restart. */
static void t_hil_error_frames(void)
{
    char rxlog[512];
    ef_sockcan_filter_t flt = {0x7FF, 0x7FF}; /* data frames: only 0x7FF; errors still come */
    ef_sockcan_t tx, rx;
    ef_can_frame_t g, f = seq_frame(0x181, 9);
    int inj = raw_injector();
    EF_CHECK(inj >= 0);
    if (inj < 0)
        return;
    if (open_pair(&tx, &rx, &flt, 1, NULL, wpath(rxlog, sizeof rxlog, "err.log")) != EF_OK) {
        close(inj);
        return;
    }

    EF_CHECK_EQ(inject(inj, CAN_ERR_FLAG | CAN_ERR_BUSOFF, NULL), 0);
    uint32_t t0 = ef_sockcan_now_us();
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 2000000), EF_ERR_AGAIN);
    EF_CHECK(!ef_time_reached(ef_sockcan_now_us(), t0 + 1000000)); /* did not wait it out */
    EF_CHECK(rx.bus & EF_SOCKCAN_BUS_OFF);
    EF_CHECK_EQ(rx.err_frames, 1);
    EF_CHECK_EQ(rx.rx, 0);
    /* bus-off: send refuses, saying so */
    EF_CHECK_EQ(ef_sockcan_send(&rx, &f), EF_ERR_BUS);
    EF_CHECK(strstr(rx.msg.text, "bus-off") && strstr(rx.msg.text, IF));
    ef_can_port_t port = ef_sockcan_port(&rx);
    EF_CHECK_EQ(port.send(port.ctx, &f), EF_ERR_BUS);
    EF_CHECK_EQ(rx.tx, 0);

    uint8_t d[8] = {0};
    d[1] = CAN_ERR_CRTL_TX_PASSIVE;
    EF_CHECK_EQ(inject(inj, CAN_ERR_FLAG | CAN_ERR_CRTL, d), 0);
    d[1] = CAN_ERR_CRTL_RX_WARNING;
    EF_CHECK_EQ(inject(inj, CAN_ERR_FLAG | CAN_ERR_CRTL, d), 0);
    /* a data frame behind the error frames is returned, the errors consumed on the way */
    ef_can_frame_t h = seq_frame(0x7FF, 10);
    EF_CHECK_EQ(ef_sockcan_send(&tx, &h), EF_OK);
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 1000000), EF_OK);
    EF_CHECK_EQ(g.id, 0x7FF);
    EF_CHECK(rx.bus & EF_SOCKCAN_ERROR_PASSIVE);
    EF_CHECK(rx.bus & EF_SOCKCAN_ERROR_WARNING);
    EF_CHECK_EQ(rx.err_frames, 3);

    EF_CHECK_EQ(inject(inj, CAN_ERR_FLAG | CAN_ERR_RESTARTED, NULL), 0);
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 1000000), EF_ERR_AGAIN);
    EF_CHECK(!(rx.bus & EF_SOCKCAN_BUS_OFF));
    EF_CHECK(rx.bus & EF_SOCKCAN_RESTARTED);
    EF_CHECK_EQ(ef_sockcan_send(&rx, &f), EF_OK); /* restarted: sends again */
    EF_CHECK_EQ(ef_sockcan_recv(&tx, &g, 1000000), EF_OK);
    EF_CHECK_EQ(g.id, 0x181);

    /* bus-off set again, then cleared by the caller */
    EF_CHECK_EQ(inject(inj, CAN_ERR_FLAG | CAN_ERR_BUSOFF, NULL), 0);
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 1000000), EF_ERR_AGAIN);
    EF_CHECK_EQ(ef_sockcan_send(&rx, &f), EF_ERR_BUS);
    rx.bus = 0;
    EF_CHECK_EQ(ef_sockcan_send(&rx, &f), EF_OK);
    ef_sockcan_close(&tx);
    ef_sockcan_close(&rx);
    close(inj);

    /* error frames are logged as candump logs them: id with CAN_ERR_FLAG, 8 hex digits */
    EF_CHECK_EQ(count_lines(rxlog, IF " 20000040#0000000000000000"), 2);
    EF_CHECK_EQ(count_lines(rxlog, IF " 20000004#0020000000000000"), 1);
    EF_CHECK_EQ(count_lines(rxlog, IF " 20000100#0000000000000000"), 1);
    EF_CHECK_EQ(count_lines(rxlog, IF " 7FF#000A"), 1);
}

/* Receive up to `want` sequence frames into got[], checking order; returns the count. */
static int drain_seq(ef_sockcan_t *rx, unsigned *next, unsigned want, uint32_t timeout_us)
{
    ef_can_frame_t g;
    int n = 0;
    while (*next < want && ef_sockcan_recv(rx, &g, timeout_us) == EF_OK) {
        if (seq_of(&g) != *next) {
            fprintf(stderr, "frame out of order: seq %u, expected %u\n", seq_of(&g), *next);
            EF_CHECK_EQ(seq_of(&g), *next);
        }
        *next = seq_of(&g) + 1;
        n++;
    }
    return n;
}

/* Flush and receive until every frame arrived or a deadline passes. */
static void flush_all(ef_sockcan_t *tx, ef_sockcan_t *rx, unsigned *next, unsigned total)
{
    uint32_t end = ef_sockcan_now_us() + 10000000u;
    while ((tx->bl_count > 0 || *next < total) && !ef_time_reached(ef_sockcan_now_us(), end)) {
        EF_CHECK_EQ(ef_sockcan_flush(tx), EF_OK);
        drain_seq(rx, next, total, 1000);
    }
}

/* ENOBUFS from a full qdisc: frames held in the backlog, back-off, all delivered in order. */
static void t_hil_enobufs(void)
{
    ef_sockcan_t tx, rx;
    unsigned next = 0, total = 60;
    int big = 1 << 22;

    if (open_pair(&tx, &rx, NULL, 0, NULL, NULL) != EF_OK)
        return;
    /* room for every frame in the receiver */
    EF_CHECK_EQ(setsockopt(rx.fd, SOL_SOCKET, SO_RCVBUFFORCE, &big, sizeof big), 0);
    /* 160 bytes: ten 16-byte CAN frames, then the qdisc drops and send() says ENOBUFS */
    if (sh("tc qdisc add dev " IF " root plug limit 160") != 0) {
        EF_CHECK(!"tc plug qdisc");
        goto out;
    }
    for (unsigned i = 0; i < total; i++) {
        ef_can_frame_t f = seq_frame(0x300, i);
        EF_CHECK_EQ(ef_sockcan_send(&tx, &f), EF_OK); /* sent or held */
    }
    EF_CHECK_EQ(tx.tx, 10);
    EF_CHECK_EQ(tx.bl_count, total - 10);
    EF_CHECK(tx.enobufs >= 1);
    EF_CHECK(tx.backoff_until_ns > 0);
    /* still plugged: repeated ENOBUFS double the back-off up to 10 ms */
    uint32_t end = ef_sockcan_now_us() + 100000u;
    while (!ef_time_reached(ef_sockcan_now_us(), end)) {
        EF_CHECK_EQ(ef_sockcan_flush(&tx), EF_OK);
        usleep_(200);
    }
    fprintf(stderr, "  plugged 100 ms: %u ENOBUFS, back-off step %u us\n", tx.enobufs,
            tx.backoff_us);
    EF_CHECK(tx.enobufs >= 5 && tx.enobufs <= 40);
    EF_CHECK_EQ(tx.backoff_us, 10000);
    EF_CHECK_EQ(tx.bl_count, total - 10);
    EF_CHECK_EQ(drain_seq(&rx, &next, total, 1000), 10); /* the ten accepted, in order */

    EF_CHECK_EQ(sh("tc qdisc change dev " IF " root plug release_indefinite"), 0);
    flush_all(&tx, &rx, &next, total);
    EF_CHECK_EQ(tx.bl_count, 0);
    EF_CHECK_EQ(tx.tx, total);
    EF_CHECK_EQ(next, total);        /* none lost, none reordered */
    EF_CHECK_EQ(tx.backoff_us, 100); /* reset by a success */

    /* Backlog full: one frame fits the qdisc, 256 the backlog, the next is refused. */
    /* (a new qdisc: "change"/"replace" would keep the released plug's state) */
    EF_CHECK_EQ(sh("tc qdisc del dev " IF " root && tc qdisc add dev " IF " root plug limit 16"),
                0);
    unsigned base = total, n2 = 1 + EF_SOCKCAN_BACKLOG;
    for (unsigned i = 0; i < n2; i++) {
        ef_can_frame_t f = seq_frame(0x300, base + i);
        EF_CHECK_EQ(ef_sockcan_send(&tx, &f), EF_OK);
    }
    EF_CHECK_EQ(tx.bl_count, EF_SOCKCAN_BACKLOG);
    ef_can_frame_t extra = seq_frame(0x300, base + n2);
    EF_CHECK_EQ(ef_sockcan_send(&tx, &extra), EF_ERR_AGAIN);
    EF_CHECK(strstr(tx.msg.text, "backlog full") && strstr(tx.msg.text, IF));
    EF_CHECK_EQ(sh("tc qdisc del dev " IF " root"), 0);
    usleep_(11000);                                   /* past the longest back-off step */
    EF_CHECK_EQ(ef_sockcan_send(&tx, &extra), EF_OK); /* the caller's retry goes through */
    total = base + n2 + 1;
    flush_all(&tx, &rx, &next, total);
    EF_CHECK_EQ(tx.bl_count, 0);
    EF_CHECK_EQ(next, total);
    EF_CHECK_EQ(tx.tx, total);

    /* A tiny send buffer with frames held in the qdisc: EAGAIN, handled the same way. */
    int one = 1;
    EF_CHECK_EQ(setsockopt(tx.fd, SOL_SOCKET, SO_SNDBUF, &one, sizeof one), 0);
    EF_CHECK_EQ(sh("tc qdisc add dev " IF " root plug limit 100000"), 0);
    uint32_t e0 = tx.enobufs;
    base = total;
    for (unsigned i = 0; i < 40; i++) {
        ef_can_frame_t f = seq_frame(0x300, base + i);
        EF_CHECK_EQ(ef_sockcan_send(&tx, &f), EF_OK);
    }
    fprintf(stderr, "  tiny SO_SNDBUF: %u frames taken by the kernel, %u held\n",
            (unsigned)(tx.tx - base), tx.bl_count);
    EF_CHECK(tx.enobufs > e0);
    EF_CHECK(tx.bl_count > 0);
    EF_CHECK_EQ(sh("tc qdisc change dev " IF " root plug release_indefinite"), 0);
    total = base + 40;
    flush_all(&tx, &rx, &next, total);
    EF_CHECK_EQ(tx.bl_count, 0);
    EF_CHECK_EQ(next, total);
    EF_CHECK_EQ(sh("tc qdisc del dev " IF " root"), 0);
out:
    ef_sockcan_close(&tx);
    ef_sockcan_close(&rx);
}

/* The interface goes down: send and recv say EF_ERR_BUS and DOWN; back up, frames flow. */
static void t_hil_down(void)
{
    ef_sockcan_t tx, rx;
    ef_can_frame_t g, f = seq_frame(0x222, 1);

    if (open_pair(&tx, &rx, NULL, 0, NULL, NULL) != EF_OK)
        return;
    EF_CHECK_EQ(sh("ip link set " IF " down"), 0);
    EF_CHECK_EQ(ef_sockcan_send(&tx, &f), EF_ERR_BUS);
    EF_CHECK(tx.bus & EF_SOCKCAN_DOWN);
    EF_CHECK(strstr(tx.msg.text, IF) && strstr(tx.msg.text, "down"));
    fprintf(stderr, "  send while down: %s\n", tx.msg.text);
    EF_CHECK_EQ(tx.bl_count, 0); /* not taken: the caller keeps it */
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 1000000), EF_ERR_BUS);
    EF_CHECK(rx.bus & EF_SOCKCAN_DOWN);
    EF_CHECK(strstr(rx.msg.text, IF) && strstr(rx.msg.text, "down"));
    fprintf(stderr, "  recv while down: %s\n", rx.msg.text);
    ef_can_port_t port = ef_sockcan_port(&tx);
    EF_CHECK_EQ(port.send(port.ctx, &f), EF_ERR_BUS);

    EF_CHECK_EQ(sh("ip link set " IF " up"), 0);
    EF_CHECK_EQ(ef_sockcan_send(&tx, &f), EF_OK);
    EF_CHECK(!(tx.bus & EF_SOCKCAN_DOWN));
    EF_CHECK_EQ(ef_sockcan_recv(&rx, &g, 1000000), EF_OK);
    EF_CHECK_EQ(g.id, 0x222);
    EF_CHECK(!(rx.bus & EF_SOCKCAN_DOWN));

    /* frames held in the backlog when the interface goes down: flush reports it */
    EF_CHECK_EQ(sh("tc qdisc add dev " IF " root plug limit 16"), 0);
    for (unsigned i = 0; i < 3; i++) {
        ef_can_frame_t h = seq_frame(0x223, i);
        EF_CHECK_EQ(ef_sockcan_send(&tx, &h), EF_OK);
    }
    EF_CHECK_EQ(tx.bl_count, 2);
    EF_CHECK_EQ(sh("tc qdisc del dev " IF " root && ip link set " IF " down"), 0);
    usleep_(11000);
    EF_CHECK_EQ(ef_sockcan_flush(&tx), EF_ERR_BUS);
    EF_CHECK(tx.bus & EF_SOCKCAN_DOWN);
    EF_CHECK_EQ(tx.bl_count, 2); /* kept for when it comes back */
    EF_CHECK_EQ(sh("ip link set " IF " up"), 0);
    EF_CHECK_EQ(ef_sockcan_flush(&tx), EF_OK);
    EF_CHECK_EQ(tx.bl_count, 0);
    ef_sockcan_close(&tx);
    ef_sockcan_close(&rx);
}

/* ------------------------------------------------------------------ transport interface */

/* The ef_canif_* calls on no transport, on SocketCAN's without CAN, and the state helpers. */
static void t_canif(void)
{
    ef_canif_t none = {NULL, NULL};
    ef_canif_cfg_t cfg = {.name = IF};
    ef_canif_status_t st;
    ef_can_frame_t f = seq_frame(0x100, 1);
    ef_msg_t m = {{0}};

    EF_CHECK_EQ(ef_canif_open(&none, &cfg, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_open(NULL, &cfg, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_send(&none, &f), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_recv(&none, &f, NULL, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_flush(&none), EF_ERR_ARG);
    ef_canif_status(&none, 0, &st);
    EF_CHECK_EQ(st.state, EF_CANIF_STATE_STOPPED);
    EF_CHECK_EQ(st.seen, 0);
    EF_CHECK_EQ(st.tec, -1);
    EF_CHECK(strcmp(ef_canif_error(&none), "") == 0);
    ef_canif_close(&none);
    ef_canif_close(NULL);
    EF_CHECK(ef_canif_port(&none).send == NULL);

    /* SocketCAN's transport: open failures as ef_sockcan_open() says them. */
    ef_sockcan_t s;
    ef_canif_t ci = ef_sockcan_canif(&s);
    EF_CHECK(strcmp(ci.ops->name, "socketcan") == 0);
    EF_CHECK_EQ(ef_canif_open(&ci, NULL, &m), EF_ERR_ARG);
    cfg.name = "nosuchcan7";
    EF_CHECK_EQ(ef_canif_open(&ci, &cfg, &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "nosuchcan7") != NULL);
    ef_canif_status(&ci, 0, &st);
    EF_CHECK_EQ(st.state, EF_CANIF_STATE_STOPPED);
    EF_CHECK_EQ(ef_canif_send(&ci, &f), EF_ERR_ARG);
    ef_can_port_t port = ef_canif_port(&ci);
    EF_CHECK_EQ(port.send(port.ctx, &f), EF_ERR_ARG);
    ef_canif_close(&ci);
    uint32_t a = ef_sockcan_now_us(), b = ef_canif_now_us(&ci);
    EF_CHECK(b - a < 1000000u);

    EF_CHECK_EQ(ef_canif_state_of(0), EF_CANIF_STATE_ACTIVE);
    EF_CHECK_EQ(ef_canif_state_of(EF_CANIF_ERROR_WARNING), EF_CANIF_STATE_WARNING);
    EF_CHECK_EQ(ef_canif_state_of(EF_CANIF_ERROR_WARNING | EF_CANIF_ERROR_PASSIVE),
                EF_CANIF_STATE_PASSIVE);
    EF_CHECK_EQ(ef_canif_state_of(EF_CANIF_BUS_OFF | EF_CANIF_ERROR_PASSIVE),
                EF_CANIF_STATE_BUS_OFF);
    EF_CHECK_EQ(ef_canif_state_of(EF_CANIF_DOWN | EF_CANIF_BUS_OFF), EF_CANIF_STATE_DOWN);
    EF_CHECK_EQ(ef_canif_state_of(EF_CANIF_RESTARTED), EF_CANIF_STATE_ACTIVE);
    EF_CHECK(strcmp(ef_canif_state_str(EF_CANIF_STATE_BUS_OFF), "bus-off") == 0);
    EF_CHECK(strcmp(ef_canif_state_str(EF_CANIF_STATE_PASSIVE), "error-passive") == 0);
    EF_CHECK(strcmp(ef_canif_state_str(99), "?") == 0);
    /* The old names are the interface's values (they reach ef_comaster_bus_error()). */
    EF_CHECK_EQ(EF_SOCKCAN_BUS_OFF, 1);
    EF_CHECK_EQ(EF_SOCKCAN_ERROR_PASSIVE, 2);
    EF_CHECK_EQ(EF_SOCKCAN_DOWN, 16);
}

/* Open port k of a bus with n filters (and a log). */
static int mem_open(ef_canmem_t *b, int k, const ef_canif_filter_t *flt, int n, const char *log)
{
    ef_canif_t ci = ef_canmem_canif(b, k);
    char name[16];
    snprintf(name, sizeof name, "mem%d", k);
    ef_canif_cfg_t c = {.name = name, .filters = flt, .n_filters = n, .log = log};
    ef_msg_t m;
    int rc = ef_canif_open(&ci, &c, &m);
    if (rc != EF_OK)
        fprintf(stderr, "open port %d: %s\n", k, m.text);
    return rc;
}

/* The in-memory bus: delivery, filters, bit budget, queue limits, conditions, overrun, log. */
static void t_canmem(void)
{
    static ef_canmem_t bus;
    ef_canif_filter_t flt = {0x100, 0x7FF | EF_CANIF_ID_EFF}; /* base 0x100 only */
    ef_can_frame_t f, g;
    ef_canif_status_t st;
    char log[512];
    uint32_t ts = 0;

    ef_canmem_init(&bus, 0);
    ef_canif_t p0 = ef_canmem_canif(&bus, 0), p1 = ef_canmem_canif(&bus, 1),
               p2 = ef_canmem_canif(&bus, 2), bad = ef_canmem_canif(&bus, EF_CANMEM_MAX_PORTS);
    EF_CHECK(bad.ctx == NULL);
    EF_CHECK_EQ(ef_canif_send(&bad, &f), EF_ERR_ARG);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, wpath(log, sizeof log, "mem0.log")), EF_OK);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, NULL), EF_ERR_ARG); /* already open */
    EF_CHECK_EQ(mem_open(&bus, 1, &flt, 1, NULL), EF_OK);
    EF_CHECK_EQ(mem_open(&bus, 2, NULL, EF_CANIF_MAX_FILTERS + 1, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_recv(&p0, &g, NULL, 1000000), EF_ERR_AGAIN); /* no wait */

    f = seq_frame(0x100, 1);
    EF_CHECK_EQ(ef_canif_send(&p2, &f), EF_ERR_ARG); /* not open */
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    f = seq_frame(0x101, 2);
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    f = seq_frame(0x100, 3);
    f.flags = EF_CAN_FLAG_EFF;
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    f.dlc = 9;
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canif_recv(&p1, &g, NULL, 0), EF_ERR_AGAIN); /* still on the bus */
    ef_canmem_advance(&bus, 300);
    ef_canmem_deliver(&bus);
    EF_CHECK_EQ(bus.frames, 3);
    EF_CHECK_EQ(ef_canif_recv(&p1, &g, &ts, 0), EF_OK);
    EF_CHECK_EQ(g.id, 0x100);
    EF_CHECK_EQ(seq_of(&g), 1);
    EF_CHECK_EQ(ts, 300);
    EF_CHECK_EQ(ef_canif_recv(&p1, &g, NULL, 0), EF_ERR_AGAIN); /* 0x101 and EFF filtered */
    EF_CHECK_EQ(ef_canif_recv(&p0, &g, NULL, 0), EF_ERR_AGAIN); /* never its own */
    EF_CHECK_EQ(ef_canif_now_us(&p1), 300);
    ef_canif_status(&p0, 0, &st);
    EF_CHECK_EQ(st.state, EF_CANIF_STATE_ACTIVE);
    EF_CHECK_EQ(st.tx, 3);
    EF_CHECK_EQ(st.tx_bits, 2u * 135u + 160u); /* the extended frame: 160 */
    ef_canif_close(&p0);
    EF_CHECK_EQ(count_lines(log, "(0000000000.000000) mem0 100#0001"), 1);
    EF_CHECK_EQ(count_lines(log, "mem0 00000100#0003"), 1);
    EF_CHECK_EQ(count_lines(log, " mem0 "), 3);
    ef_canif_close(&p0); /* closed: harmless */

    /* 1 Mbit/s: a 135-bit frame needs 135 us of bus time; an idle bus saves none. */
    ef_canif_close(&p1);
    ef_canmem_init(&bus, 1000000u);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, NULL), EF_OK);
    EF_CHECK_EQ(mem_open(&bus, 1, NULL, 0, NULL), EF_OK);
    ef_canmem_advance(&bus, 10000);
    ef_canmem_deliver(&bus); /* idle: the 10 000 bits are gone */
    for (unsigned i = 0; i < 2; i++) {
        f = seq_frame(0x200, i);
        EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    }
    ef_canmem_advance(&bus, 100);
    ef_canmem_deliver(&bus);
    EF_CHECK_EQ(bus.frames, 0);
    ef_canmem_advance(&bus, 100);
    ef_canmem_deliver(&bus);
    EF_CHECK_EQ(bus.frames, 1);
    ef_canmem_advance(&bus, 100);
    ef_canmem_deliver(&bus);
    EF_CHECK_EQ(bus.frames, 2);
    EF_CHECK_EQ(bus.bits, 270);
    EF_CHECK_EQ(bus.frames_fn[4], 2);
    EF_CHECK_EQ(ef_canif_recv(&p1, &g, &ts, 0), EF_OK);
    EF_CHECK_EQ(ts, 10200);
    EF_CHECK_EQ(ef_canif_recv(&p1, &g, &ts, 0), EF_OK);
    EF_CHECK_EQ(ts, 10300);

    /* A full bus queue: the frame is refused, the caller keeps it. */
    bus.txcap = 2;
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_ERR_AGAIN);
    EF_CHECK(strstr(ef_canif_error(&p0), "queue full") && strstr(ef_canif_error(&p0), "mem0"));
    ef_canif_status(&p0, 0, &st);
    EF_CHECK_EQ(st.tx_full, 1);
    EF_CHECK_EQ(st.tx_pending, 0);
    EF_CHECK_EQ(ef_canif_flush(&p0), EF_OK); /* nothing held: no flush op */

    /* Conditions: bus-off refuses sends until cleared (or a restart). */
    ef_canmem_raise(&bus, 0, EF_CANIF_BUS_OFF | EF_CANIF_ERROR_PASSIVE);
    EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_ERR_BUS);
    EF_CHECK(strstr(ef_canif_error(&p0), "bus-off") != NULL);
    ef_canif_status(&p0, EF_CANIF_BUS_OFF, &st);
    EF_CHECK_EQ(st.state, EF_CANIF_STATE_BUS_OFF);
    EF_CHECK_EQ(st.seen, EF_CANIF_BUS_OFF | EF_CANIF_ERROR_PASSIVE);
    ef_canif_status(&p0, 0, &st);
    EF_CHECK_EQ(st.seen, EF_CANIF_ERROR_PASSIVE);
    EF_CHECK_EQ(st.state, EF_CANIF_STATE_PASSIVE);
    ef_canmem_raise(&bus, 0, EF_CANIF_BUS_OFF);
    ef_canmem_raise(&bus, 0, EF_CANIF_RESTARTED);
    ef_canif_status(&p0, ~0u, &st);
    EF_CHECK_EQ(st.seen, EF_CANIF_ERROR_PASSIVE | EF_CANIF_RESTARTED);
    EF_CHECK_EQ(st.err_frames, 3);

    /* A receiver that does not read loses what its queue cannot hold. */
    ef_canmem_init(&bus, 0);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, NULL), EF_OK);
    EF_CHECK_EQ(mem_open(&bus, 1, NULL, 0, NULL), EF_OK);
    for (unsigned i = 0; i < EF_CANMEM_RXQ + 10; i++) {
        f = seq_frame(0x300, i);
        EF_CHECK_EQ(ef_canif_send(&p0, &f), EF_OK);
    }
    ef_canmem_deliver(&bus);
    ef_canif_status(&p1, 0, &st);
    EF_CHECK_EQ(st.rx_overrun, 10);
    unsigned next = 0;
    while (ef_canif_recv(&p1, &g, NULL, 0) == EF_OK) {
        EF_CHECK_EQ(seq_of(&g), next);
        next++;
    }
    EF_CHECK_EQ(next, EF_CANMEM_RXQ);
    ef_canif_close(&p0);
    ef_canif_close(&p1);
}

/* What a test node saw, in order. */
typedef struct {
    char ev[64][24];
    int n;
    uint32_t next_us; /* what process asks for */
    uint32_t bus;     /* conditions passed, or-ed */
    int bus_calls;
    ef_canif_t *reply; /* process sends one frame here when set */
} pump_node_t;

static int pn_rx(void *obj, const ef_can_frame_t *f, uint32_t ts_us)
{
    pump_node_t *n = obj;
    if (n->n < 64)
        snprintf(n->ev[n->n++], sizeof n->ev[0], "rx %X@%u", (unsigned)f->id, (unsigned)ts_us);
    return EF_OK;
}

static int pn_process(void *obj, uint32_t dt_us, uint32_t *next_us)
{
    pump_node_t *n = obj;
    if (n->n < 64)
        snprintf(n->ev[n->n++], sizeof n->ev[0], "proc %u", (unsigned)dt_us);
    if (n->next_us)
        *next_us = n->next_us;
    if (n->reply) {
        ef_can_frame_t f = seq_frame(0x580, 0);
        ef_canif_send(n->reply, &f);
    }
    return EF_OK;
}

static void pn_bus(void *obj, uint32_t conditions)
{
    pump_node_t *n = obj;
    n->bus |= conditions;
    n->bus_calls++;
}

/* Events of a node as one string, for comparison. */
static const char *pn_str(pump_node_t *n, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; i < n->n; i++)
        snprintf(buf + strlen(buf), len - strlen(buf), "%s%s", i ? "; " : "", n->ev[i]);
    n->n = 0;
    return buf;
}

/* A transport whose receive fails: the pump ends, once, with its message. */
static int fk_open(void *ctx, const ef_canif_cfg_t *c, ef_msg_t *m)
{
    (void)ctx;
    (void)c;
    (void)m;
    return EF_OK;
}
static void fk_close(void *ctx)
{
    (void)ctx;
}
static int fk_send(void *ctx, const ef_can_frame_t *f)
{
    (void)ctx;
    (void)f;
    return EF_OK;
}
static int fk_recv(void *ctx, ef_can_frame_t *f, uint32_t *ts, uint32_t timeout_us)
{
    (void)ctx;
    (void)f;
    (void)ts;
    (void)timeout_us;
    return EF_ERR_IO;
}
static void fk_status(void *ctx, uint32_t clear, ef_canif_status_t *st)
{
    (void)ctx;
    (void)clear;
    st->state = EF_CANIF_STATE_ACTIVE;
}
static const char *fk_error(void *ctx)
{
    (void)ctx;
    return "fake0: recv: broken";
}

/* The pump: frames before time, the held frame, bursts, bus conditions, errors. */
static void t_canpump(void)
{
    static ef_canmem_t bus;
    pump_node_t nd;
    ef_canpump_t p;
    ef_canpump_cfg_t pc;
    char buf[1024];
    ef_can_frame_t f, g;
    memset(&nd, 0, sizeof nd);

    ef_canmem_init(&bus, 0);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, NULL), EF_OK);
    EF_CHECK_EQ(mem_open(&bus, 1, NULL, 0, NULL), EF_OK);
    ef_canif_t ci = ef_canmem_canif(&bus, 0), peer = ef_canmem_canif(&bus, 1);
    ef_canpump_node_t node = {pn_rx, pn_process, pn_bus, &nd};
    ef_canpump_node_t half = {pn_rx, NULL, NULL, &nd};
    EF_CHECK_EQ(ef_canpump_init(&p, &ci, &half, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_canpump_init(NULL, &ci, &node, NULL), EF_ERR_ARG);
    ef_canpump_cfg_default(&pc);
    EF_CHECK_EQ(pc.rx_burst, 64);
    pc.rx_burst = 2;
    EF_CHECK_EQ(ef_canpump_init(&p, &ci, &node, &pc), EF_OK);

    /* Frames received before the clock reading go to the node before its time does. */
    f = seq_frame(0x10, 0);
    EF_CHECK_EQ(ef_canif_send(&peer, &f), EF_OK);
    ef_canmem_advance(&bus, 50);
    ef_canmem_deliver(&bus);
    ef_canmem_advance(&bus, 50);
    EF_CHECK_EQ(ef_canpump_poll(&p, 1000), EF_OK);
    EF_CHECK(strcmp(pn_str(&nd, buf, sizeof buf), "rx 10@50; proc 100") == 0);
    EF_CHECK_EQ(ef_canpump_elapsed_us(&p), 100);

    /* A burst of 2: the third frame is taken by the wait and held for the next round. */
    for (unsigned i = 1; i <= 4; i++) {
        f = seq_frame(0x10 + i, i);
        EF_CHECK_EQ(ef_canif_send(&peer, &f), EF_OK);
    }
    ef_canmem_deliver(&bus);
    ef_canmem_advance(&bus, 10);
    EF_CHECK_EQ(ef_canpump_poll(&p, 1000), EF_OK);
    EF_CHECK(strcmp(pn_str(&nd, buf, sizeof buf), "rx 11@100; rx 12@100; proc 10") == 0);
    EF_CHECK_EQ(ef_canpump_rx_frames(&p), 4); /* the held one is counted */
    EF_CHECK_EQ(ef_canpump_rx_bits(&p), 4u * 135u);
    ef_canmem_advance(&bus, 20);
    EF_CHECK_EQ(ef_canpump_poll(&p, 1000), EF_OK);
    EF_CHECK(strcmp(pn_str(&nd, buf, sizeof buf), "rx 13@100; rx 14@100; proc 20") == 0);
    EF_CHECK_EQ(ef_canpump_elapsed_us(&p), 130);

    /* What the node sends in process reaches the bus. */
    nd.reply = &ci;
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    nd.reply = NULL;
    ef_canmem_deliver(&bus);
    EF_CHECK_EQ(ef_canif_recv(&peer, &g, NULL, 0), EF_OK);
    EF_CHECK_EQ(g.id, 0x580);
    pn_str(&nd, buf, sizeof buf);

    /* Bus conditions: each passed once; without bus_clear bus-off stays (sends refused). */
    ef_canmem_raise(&bus, 0, EF_CANIF_ERROR_WARNING);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(nd.bus_calls, 0); /* a warning stops nothing */
    ef_canmem_raise(&bus, 0, EF_CANIF_ERROR_PASSIVE);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(nd.bus_calls, 1);
    EF_CHECK_EQ(nd.bus, EF_CANIF_ERROR_PASSIVE);
    ef_canmem_raise(&bus, 0, EF_CANIF_BUS_OFF);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(nd.bus_calls, 2);
    EF_CHECK_EQ(nd.bus, EF_CANIF_ERROR_PASSIVE | EF_CANIF_BUS_OFF);
    EF_CHECK_EQ(ef_canif_send(&ci, &f), EF_ERR_BUS);
    pn_str(&nd, buf, sizeof buf);

    /* With bus_clear (a master's controlled stop must still be tried): cleared once passed. */
    ef_canmem_init(&bus, 0);
    EF_CHECK_EQ(mem_open(&bus, 0, NULL, 0, NULL), EF_OK);
    memset(&nd, 0, sizeof nd);
    ef_canpump_cfg_default(&pc);
    pc.bus_clear = EF_CANIF_BUS_OFF;
    EF_CHECK_EQ(ef_canpump_init(&p, &ci, &node, &pc), EF_OK);
    ef_canmem_raise(&bus, 0, EF_CANIF_BUS_OFF);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(nd.bus_calls, 1);
    EF_CHECK_EQ(nd.bus, EF_CANIF_BUS_OFF);
    EF_CHECK_EQ(ef_canif_send(&ci, &f), EF_OK);
    ef_canmem_raise(&bus, 0, EF_CANIF_BUS_OFF); /* seen again: already passed on */
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_OK);
    EF_CHECK_EQ(nd.bus_calls, 1);
    EF_CHECK_EQ(ef_canif_send(&ci, &f), EF_OK);
    EF_CHECK_EQ(ef_canpump_error(&p), EF_OK);
    EF_CHECK(strcmp(ef_canpump_msg(&p), "") == 0);
    ef_canif_close(&ci);
    ef_canif_close(&peer);

    /* A transport error ends the pump: kept, with the transport's message, node not run. */
    static const ef_canif_ops_t fk = {
        .name = "fake",
        .open = fk_open,
        .close = fk_close,
        .send = fk_send,
        .recv = fk_recv,
        .status = fk_status,
        .error = fk_error,
    };
    ef_canif_t fci = {&fk, NULL};
    memset(&nd, 0, sizeof nd);
    EF_CHECK_EQ(ef_canpump_init(&p, &fci, &node, NULL), EF_OK);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_ERR_IO);
    EF_CHECK(strstr(ef_canpump_msg(&p), "fake0: recv: broken") != NULL);
    EF_CHECK_EQ(ef_canpump_poll(&p, 0), EF_ERR_IO);
    EF_CHECK_EQ(ef_canpump_error(&p), EF_ERR_IO);
    EF_CHECK_EQ(nd.n, 0);
}

/* Run the offline or the in-guest group. */
/* test_sockcan offline|hil WORKDIR [PART...]: offline runs the parts that need no CAN
 * interface; hil (in the guest, vcan0 up) runs those and the rest. The runner names each
 * part on stderr as it starts it, so a hung guest shows where it stopped. */
int main(int argc, char **argv)
{
/* Parts that need no CAN interface; the parts that do follow them in hil[]. */
/* clang-format off */
#define SC_OFFLINE_PARTS                                                                           \
    {"open_errors", t_open_errors},                                                                \
    {"log_format", t_log_format},                                                                  \
    {"frame_bits", t_frame_bits},                                                                  \
    {"canif", t_canif},                                                                            \
    {"canmem", t_canmem},                                                                          \
    {"canpump", t_canpump}
    /* clang-format on */
    static const ef_test_part_t offline[] = {SC_OFFLINE_PARTS};
    static const ef_test_part_t hil[] = {
        SC_OFFLINE_PARTS,
        {"hil_open", t_hil_open},
        {"hil_filters_and_log", t_hil_filters_and_log},
        {"hil_error_frames", t_hil_error_frames},
        {"hil_enobufs", t_hil_enobufs},
        {"hil_down", t_hil_down},
    };
#undef SC_OFFLINE_PARTS
    if (argc < 3 || (strcmp(argv[1], "offline") != 0 && strcmp(argv[1], "hil") != 0)) {
        fprintf(stderr, "usage: %s offline|hil WORKDIR [PART...]\n", argv[0]);
        return 2;
    }
    snprintf(workdir, sizeof workdir, "%s", argv[2]);
    if (strcmp(argv[1], "hil") == 0)
        return EF_TEST_RUN(argc, argv, 3, hil);
    return EF_TEST_RUN(argc, argv, 3, offline);
}
