/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream: smooth a part program and stream it to a drive (docs/modbus.md). */
#include <math.h>
#include <net/if.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/modbus/ef_mb.h"

static const char usage[] =
    "usage: evenfeed stream --modbus ADDRESS [options] PROGRAM.ngc\n"
    "       evenfeed stream --can IFACE [options] PROGRAM.ngc\n"
    "\n"
    "Smooth PROGRAM and stream it to evenfeed drives: one Modbus drive (docs/modbus.md)\n"
    "or up to three CANopen CiA 402 drives on a SocketCAN interface (docs/can.md).\n"
    "ADDRESS is tcp://HOST:PORT or rtu:DEVICE[,BAUD[,8N1]] (default 115200,8N1).\n"
    "\n"
    "Modbus:\n"
    "  --slave N         unit id / slave address, 1..247 (default 1)\n"
    "  --mode M          segment (default): whole Bezier segments into the drive's ring;\n"
    "                    direct: sampled target positions, one write each\n"
    "  --direct-hz HZ    direct mode: targets per second (default 50)\n"
    "  --timeout MS      response timeout per transaction (default 200)\n"
    "  --retries N       further attempts per transaction (default 3)\n"
    "  --watchdog MS     the drive faults if the master is silent this long while\n"
    "                    running (default 1000; 0 off)\n"
    "CAN (CANopen master on IFACE, e.g. vcan0):\n"
    "  --nodes A[,B[,C]] node ids 1..127 moving x, y, z (default 1,2,3)\n"
    "  --mode M          segment (default): segments as PDO chunks into each drive's ring;\n"
    "                    csp: cyclic synchronous position, one target per node per SYNC\n"
    "  --cycle-us US     SYNC period (default: csp 1000, segment 10000); in csp mode the\n"
    "                    interpolator runs at this period (--period-us is not used)\n"
    "  --hb-timeout MS   a node whose heartbeat is silent this long is lost (default 200;\n"
    "                    the drives are asked for one every 50 ms)\n"
    "  --log FILE        candump log (candump -l format) of the bus traffic\n"
    "  --trace FILE      CSV: SYNC times, actual positions, targets, segments\n"
    "both:\n"
    "  --fault-reset     reset faulted drives first (default: refuse to enable them)\n"
    "  -v                progress on stderr\n"
    "  smoothing: --tol MM --vmax MM/S --amax MM/S2 --jerk MM/S3 --micro-len MM --g1\n"
    "             --period-us US --step uniform|corrected (as evenfeed smooth)\n"
    "\n"
    "Exit status 0 when every segment executed; otherwise the negated error code, with\n"
    "the drives told to stop under control.\n";

/* Parse an integer option within [lo, hi]. */
static int st_int(const char *opt, const char *v, long lo, long hi, long *out)
{
    char *end;
    if (!v)
        return ef_cli_error(EF_ERR_ARG, "stream: %s needs a value", opt);
    long x = strtol(v, &end, 10);
    if (end == v || *end || x < lo || x > hi)
        return ef_cli_error(EF_ERR_ARG, "stream: %s '%s': a whole number %ld..%ld", opt, v, lo, hi);
    *out = x;
    return 0;
}

/* Parse --nodes A[,B[,C]]: ids 1..127, no repeats, 1..3 of them. */
static int st_nodes(const char *v, ef_can_stream_cfg_t *cc)
{
    if (!v || !*v)
        return ef_cli_error(EF_ERR_ARG, "stream: --nodes needs a list, e.g. 1,2,3");
    uint8_t ids[EF_CAN_STREAM_MAX_NODES];
    int n = 0;
    const char *p = v;
    for (;;) {
        char *end;
        long x = strtol(p, &end, 10);
        if (end == p || (*end && *end != ','))
            return ef_cli_error(EF_ERR_ARG, "stream: --nodes '%s': node ids separated by commas",
                                v);
        if (x < 1 || x > 127)
            return ef_cli_error(EF_ERR_ARG, "stream: --nodes '%s': node id %ld not 1..127", v, x);
        if (n >= EF_CAN_STREAM_MAX_NODES)
            return ef_cli_error(EF_ERR_ARG, "stream: --nodes '%s': at most %d nodes (x, y, z)", v,
                                EF_CAN_STREAM_MAX_NODES);
        for (int j = 0; j < n; j++)
            if (ids[j] == x)
                return ef_cli_error(EF_ERR_ARG, "stream: --nodes '%s': node %ld given twice", v, x);
        ids[n++] = (uint8_t)x;
        if (!*end)
            break;
        p = end + 1;
    }
    memcpy(cc->nodes, ids, sizeof ids);
    cc->n_nodes = (uint8_t)n;
    return 0;
}

/* Stream over CAN with the parsed options; print the summary; the exit status. */
static int st_run_can(const ef_can_stream_cfg_t *cc, const char *path)
{
    static ef_gcode_t r; /* about 50 kB: not on the stack */
    ef_msg_t m = {{0}};
    int rc = ef_gcode_open(&r, path, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    ef_can_stream_result_t res;
    rc = ef_can_stream(&r, cc, &res, &m);
    ef_gcode_free(&r);
    char nodes[64] = "";
    for (int k = 0; k < cc->n_nodes; k++)
        snprintf(nodes + strlen(nodes), sizeof nodes - strlen(nodes), "%s%u", k ? "," : "",
                 (unsigned)cc->nodes[k]);
    int csp = cc->mode == EF_COM_MODE_CSP;
    if (csp)
        printf("stream: %u targets (%u moves) to %s nodes %s, csp: path time %.3f s, wall time "
               "%.3f s, %u of %u executed, %u starved cycles\n",
               res.targets, res.moves, cc->iface, nodes, res.path_time, res.wall_time, res.executed,
               res.targets, res.starved);
    else
        printf("stream: %u segments to %s nodes %s, segment mode: path time %.3f s, wall time "
               "%.3f s, %u of %u executed, %u resends\n",
               res.segments, cc->iface, nodes, res.path_time, res.wall_time, res.executed,
               res.segments, res.resends);
    printf("sync: %u SYNCs, period mean %.1f us, std %.1f us, min %.1f us, max %.1f us\n",
           res.syncs, res.sync_mean_us, res.sync_std_us, res.sync_min_us, res.sync_max_us);
    printf("bus: master sent %llu frames (%llu bits, %.3f s at %.0f kbit/s), received %llu "
           "frames; load %.1f %%, %u error frames\n",
           (unsigned long long)res.tx_frames, (unsigned long long)res.tx_bits, res.bus_time_s,
           cc->bitrate / 1000.0, (unsigned long long)res.rx_frames, 100.0 * res.load,
           res.err_frames);
    printf("drives:");
    for (int k = 0; k < cc->n_nodes; k++)
        printf("%s node %u \"%s\"", k ? "," : "", (unsigned)cc->nodes[k], res.names[k]);
    printf("; master state %d\n", res.state);
    fflush(stdout);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    return 0;
}

/* Entry point of `evenfeed stream`. */
int ef_cmd_stream(int argc, char **argv)
{
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, ef_cli_default_table(EF_TABLE_G2_QUINTIC),
                             ef_cli_default_table(EF_TABLE_G1_CUBIC));
    ef_can_stream_cfg_t cc;
    ef_can_stream_cfg_default(&cc, c.pipe.g2, c.pipe.g1);
    const char *path = NULL, *addr = NULL, *iface = NULL, *mode = NULL;
    const char *mb_only = NULL, *can_only = NULL; /* an option of one transport, given */
    ef_msg_t m = {{0}};
    for (int k = 1; k < argc; k++) {
        const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;
        long x = 0;
        int rc, used;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--modbus")) {
            if (!v)
                return ef_cli_error(EF_ERR_ARG, "stream: --modbus needs an address");
            if (ef_mb_url_parse(v, &c.mb, &m) != EF_OK)
                return ef_cli_error(EF_ERR_ARG, "stream: --modbus: %s", m.text);
            addr = v;
            k++;
        } else if (!strcmp(a, "--can")) {
            if (!v || !*v || *v == '-')
                return ef_cli_error(EF_ERR_ARG, "stream: --can needs an interface, e.g. vcan0");
            if (strlen(v) >= 16) /* IFNAMSIZ */
                return ef_cli_error(EF_ERR_ARG, "stream: --can '%s': interface name too long", v);
            iface = v;
            k++;
        } else if (!strcmp(a, "--nodes")) {
            if ((rc = st_nodes(v, &cc)))
                return rc;
            can_only = a;
            k++;
        } else if (!strcmp(a, "--cycle-us")) {
            if ((rc = st_int(a, v, 100, 1000000, &x)))
                return rc;
            cc.cycle_us = (uint32_t)x;
            can_only = a;
            k++;
        } else if (!strcmp(a, "--hb-timeout")) {
            if ((rc = st_int(a, v, 100, 60000, &x)))
                return rc;
            cc.hb_timeout_ms = (uint32_t)x;
            can_only = a;
            k++;
        } else if (!strcmp(a, "--log") || !strcmp(a, "--trace")) {
            if (!v)
                return ef_cli_error(EF_ERR_ARG, "stream: %s needs a file name", a);
            if (a[2] == 'l')
                cc.log = v;
            else
                cc.trace = v;
            can_only = a;
            k++;
        } else if (!strcmp(a, "--slave")) {
            if ((rc = st_int(a, v, 1, 247, &x)))
                return rc;
            c.mb.slave = (int)x;
            mb_only = a;
            k++;
        } else if (!strcmp(a, "--mode")) {
            if (!v || (strcmp(v, "segment") && strcmp(v, "direct") && strcmp(v, "csp")))
                return ef_cli_error(EF_ERR_ARG,
                                    "stream: --mode segment|direct (Modbus), segment|csp (CAN)");
            mode = v;
            k++;
        } else if (!strcmp(a, "--direct-hz")) {
            if ((rc = st_int(a, v, 1, 10000, &x)))
                return rc;
            c.direct_hz = (double)x;
            mb_only = a;
            k++;
        } else if (!strcmp(a, "--timeout")) {
            if ((rc = st_int(a, v, 1, 60000, &x)))
                return rc;
            c.mb.timeout_s = x * 1e-3;
            mb_only = a;
            k++;
        } else if (!strcmp(a, "--retries")) {
            if ((rc = st_int(a, v, 0, 100, &x)))
                return rc;
            c.mb.retries = (int)x;
            mb_only = a;
            k++;
        } else if (!strcmp(a, "--watchdog")) {
            if ((rc = st_int(a, v, 0, 65535, &x)))
                return rc;
            c.mb.watchdog_ms = (uint16_t)x;
            mb_only = a;
            k++;
        } else if (!strcmp(a, "--fault-reset")) {
            c.fault_reset = 1;
        } else if (!strcmp(a, "-v")) {
            c.verbose = 1;
        } else if ((rc = ef_cli_pipe_opt("stream", a, v, &c.pipe, &used)) >= 0) {
            if (rc)
                return rc;
            k += used;
        } else if (a[0] == '-' && a[1]) {
            return ef_cli_error(EF_ERR_ARG, "stream: unknown option '%s'", a);
        } else if (path) {
            return ef_cli_error(EF_ERR_ARG, "stream: one program only ('%s')", a);
        } else {
            path = a;
        }
    }
    if (addr && iface)
        return ef_cli_error(EF_ERR_ARG, "stream: --modbus or --can, not both");
    if ((!addr && !iface) || !path) {
        fputs(usage, stderr);
        return ef_cli_error(EF_ERR_ARG, "stream: %s",
                            !addr && !iface ? "no --modbus address or --can interface"
                                            : "no program");
    }
    if (iface && mb_only)
        return ef_cli_error(EF_ERR_ARG, "stream: %s is a Modbus option (not with --can)", mb_only);
    if (addr && can_only)
        return ef_cli_error(EF_ERR_ARG, "stream: %s is a CAN option (not with --modbus)", can_only);
    if (mode && !strcmp(mode, iface ? "direct" : "csp"))
        return ef_cli_error(EF_ERR_ARG, "stream: --mode %s is not a %s mode (%s)", mode,
                            iface ? "CAN" : "Modbus", iface ? "segment|csp" : "segment|direct");
    if (!c.pipe.g2 || (c.pipe.smooth_degree == 3 && !c.pipe.g1))
        return ef_cli_error(EF_ERR_ARG, "stream: this binary has no built-in tables");
    if (iface) {
        if (if_nametoindex(iface) == 0) /* before the program: name the interface first */
            return ef_cli_error(EF_ERR_IO, "stream: --can %s: no such network interface", iface);
        cc.iface = iface;
        cc.pipe = c.pipe;
        cc.mode = mode && !strcmp(mode, "csp") ? EF_COM_MODE_CSP : EF_COM_MODE_SEGMENT;
        cc.fault_reset = (uint8_t)c.fault_reset;
        cc.verbose = (uint8_t)c.verbose;
        return st_run_can(&cc, path);
    }
    if (mode)
        c.mode = !strcmp(mode, "direct") ? EF_MB_MODE_DIRECT : EF_MB_MODE_SEGMENT;
    static ef_gcode_t r; /* about 50 kB: not on the stack */
    int rc = ef_gcode_open(&r, path, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    ef_mb_stream_result_t res;
    rc = ef_mb_stream(&r, &c, &res, &m);
    ef_gcode_free(&r);
    const ef_mb_stats_t *io = &res.io;
    double span = io->t_last - io->t_first;
    if (c.mode == EF_MB_MODE_SEGMENT)
        printf("stream: %u segments to %s: path time %.3f s, wall time %.3f s, %.0f segments/s "
               "while writing\n",
               res.moves, addr, res.path_time, res.wall_time,
               span > 0.0 ? (io->slot_writes - 1) / span : 0.0);
    else
        printf("stream: %u direct targets to %s at %.0f Hz: path time %.3f s, wall time %.3f s\n",
               res.targets, addr, c.direct_hz, res.path_time, res.wall_time);
    printf("transport: %llu transactions, %llu retries (%llu after timeouts), %llu reconnects, "
           "%llu waits for a free slot, %llu status reads\n",
           (unsigned long long)io->transactions, (unsigned long long)io->retries,
           (unsigned long long)io->timeouts, (unsigned long long)io->reconnects,
           (unsigned long long)io->busy, (unsigned long long)io->polls);
    printf("drive: state %u, fault %u, %u segments executed, following error max %.4f mm, "
           "%u duplicate writes acknowledged, %u writes refused\n",
           res.last.state, res.last.fault, res.last.done_count, (double)res.last.ferr_max,
           res.last.duplicates, res.last.rejected);
    fflush(stdout);
    if (rc != EF_OK)
        return ef_cli_error(rc, "stream: %s", m.text);
    return 0;
}
