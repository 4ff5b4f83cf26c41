/* evenfeed stream: smooth a part program and stream it to a drive (docs/modbus.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/ef_mb.h"

static const char usage[] =
    "usage: evenfeed stream --modbus ADDRESS [options] PROGRAM.ngc\n"
    "\n"
    "Smooth PROGRAM and stream its segments to an evenfeed Modbus drive (docs/modbus.md).\n"
    "ADDRESS is tcp://HOST:PORT or rtu:DEVICE[,BAUD[,8N1]] (default 115200,8N1).\n"
    "\n"
    "  --slave N         unit id / slave address, 1..247 (default 1)\n"
    "  --mode M          segment (default): whole Bezier segments into the drive's ring;\n"
    "                    direct: sampled target positions, one write each\n"
    "  --direct-hz HZ    direct mode: targets per second (default 50)\n"
    "  --timeout MS      response timeout per transaction (default 200)\n"
    "  --retries N       further attempts per transaction (default 3)\n"
    "  --watchdog MS     the drive faults if the master is silent this long while\n"
    "                    running (default 1000; 0 off)\n"
    "  --fault-reset     reset a faulted drive first (default: refuse to enable it)\n"
    "  -v                progress on stderr\n"
    "  smoothing: --tol MM --vmax MM/S --amax MM/S2 --jerk MM/S3 --micro-len MM --g1\n"
    "             --period-us US --step uniform|corrected (as evenfeed smooth)\n"
    "\n"
    "Exit status 0 when every segment executed; otherwise the negated error code, with\n"
    "the drive told to stop under control.\n";

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

/* Entry point of `evenfeed stream`. */
int ef_cmd_stream(int argc, char **argv)
{
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, ef_cli_default_table(EF_TABLE_G2_QUINTIC),
                             ef_cli_default_table(EF_TABLE_G1_CUBIC));
    const char *path = NULL, *addr = NULL;
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
            return ef_cli_error(EF_ERR_ARG, "stream: --can: CAN streaming is not built yet "
                                            "(issue 5); use --modbus");
        } else if (!strcmp(a, "--slave")) {
            if ((rc = st_int(a, v, 1, 247, &x)))
                return rc;
            c.mb.slave = (int)x;
            k++;
        } else if (!strcmp(a, "--mode")) {
            if (v && !strcmp(v, "segment"))
                c.mode = EF_MB_MODE_SEGMENT;
            else if (v && !strcmp(v, "direct"))
                c.mode = EF_MB_MODE_DIRECT;
            else
                return ef_cli_error(EF_ERR_ARG, "stream: --mode segment|direct");
            k++;
        } else if (!strcmp(a, "--direct-hz")) {
            if ((rc = st_int(a, v, 1, 10000, &x)))
                return rc;
            c.direct_hz = (double)x;
            k++;
        } else if (!strcmp(a, "--timeout")) {
            if ((rc = st_int(a, v, 1, 60000, &x)))
                return rc;
            c.mb.timeout_s = x * 1e-3;
            k++;
        } else if (!strcmp(a, "--retries")) {
            if ((rc = st_int(a, v, 0, 100, &x)))
                return rc;
            c.mb.retries = (int)x;
            k++;
        } else if (!strcmp(a, "--watchdog")) {
            if ((rc = st_int(a, v, 0, 65535, &x)))
                return rc;
            c.mb.watchdog_ms = (uint16_t)x;
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
    if (!addr || !path) {
        fputs(usage, stderr);
        return ef_cli_error(EF_ERR_ARG, "stream: %s", !addr ? "no --modbus address" : "no program");
    }
    if (!c.pipe.g2 || (c.pipe.smooth_degree == 3 && !c.pipe.g1))
        return ef_cli_error(EF_ERR_ARG, "stream: this binary has no built-in tables");
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
