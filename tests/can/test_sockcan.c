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

/* Run the offline or the in-guest group. */
int main(int argc, char **argv)
{
    if (argc < 3 || (strcmp(argv[1], "offline") != 0 && strcmp(argv[1], "hil") != 0)) {
        fprintf(stderr, "usage: %s offline|hil WORKDIR\n", argv[0]);
        return 2;
    }
    snprintf(workdir, sizeof workdir, "%s", argv[2]);
    t_open_errors();
    t_log_format();
    t_frame_bits();
    if (strcmp(argv[1], "hil") == 0) {
        fprintf(stderr, "open\n");
        t_hil_open();
        fprintf(stderr, "filters and log\n");
        t_hil_filters_and_log();
        fprintf(stderr, "error frames\n");
        t_hil_error_frames();
        fprintf(stderr, "ENOBUFS\n");
        t_hil_enobufs();
        fprintf(stderr, "interface down\n");
        t_hil_down();
    }
    return ef_test_summary();
}
