/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream: smooth a part program and stream it to a drive (docs/modbus.md). */
#include <limits.h>
#include <net/if.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/can/ef_gsusb.h"
#include "evenfeed/host/modbus/ef_mb.h"
#include "evenfeed/host/io/ef_mio.h"

static const char usage[] =
    "usage: evenfeed stream --modbus ADDRESS[=AXES[@UNIT]] [--modbus ...] [options] "
    "PROGRAM.ngc\n"
    "       evenfeed stream --can IFACE [options] PROGRAM.ngc\n"
    "       evenfeed stream --can gsusb[:SERIAL][@BITRATE] [options] PROGRAM.ngc\n"
    "\n"
    "Smooth PROGRAM and stream it to evenfeed drives: Modbus drives (docs/modbus.md)\n"
    "or up to nine CANopen CiA 402 drives on a SocketCAN interface or a USB-CAN adapter\n"
    "speaking gs_usb, driven through libusb (docs/can.md).\n"
    "ADDRESS is tcp://HOST:PORT or rtu:DEVICE[,BAUD[,8N1]] (default 115200,8N1).\n"
    "\n"
    "Modbus:\n"
    "  --modbus A[=AXES[@UNIT]]  up to nine drives, AXES xyz (3-axis drive) or one of\n"
    "                    x y z a b c u v w; e.g. tcp://h:1502=xyz, tcp://h:1503=a\n"
    "  --skew-ms MS      stop all drives when their executed times differ by more (20)\n"
    "  --slave N         unit id / slave address, 1..247 (default 1)\n"
    "  --mode M          segment (default): whole Bezier segments into the drive's ring;\n"
    "                    direct: sampled target positions, one write each (one drive)\n"
    "  --direct-hz HZ    direct mode: targets per second (default 50)\n"
    "  --timeout MS      response timeout per transaction (default 200)\n"
    "  --retries N       further attempts per transaction (default 3)\n"
    "  --watchdog MS     the drive faults if the master is silent this long while\n"
    "                    running (default 1000; 0 off)\n"
    "CAN (CANopen master on IFACE, e.g. vcan0, or on a gs_usb adapter):\n"
    "  --can gsusb...    a USB-CAN adapter (candleLight, CANable) instead of SocketCAN:\n"
    "                    gsusb (the only one), gsusb:SERIAL or gsusb:BUS-PORT (as\n"
    "                    `evenfeed can list` shows them), @BITRATE in bit/s (default\n"
    "                    1000000; also used for the bus-load figure)\n"
    "  --can-opts LIST   gs_usb channel options, comma-separated: loopback, listen-only,\n"
    "                    one-shot, timestamps (required), no-timestamps, channel=N,\n"
    "                    timeout=MS (a bulk OUT's bound, default 1000; echo: twice it)\n"
    "  --nodes A[,B,...] node ids 1..127 moving x, y, z, then a b c u v w (default 1,2,3)\n"
    "  --mode M          segment (default): segments as PDO chunks into each drive's ring;\n"
    "                    csp: cyclic synchronous position, one target per node per SYNC\n"
    "  --cycle-us US     SYNC period (default: csp 1000, segment 10000); in csp mode the\n"
    "                    interpolator runs at this period (--period-us is not used)\n"
    "  --hb-timeout MS   a node whose heartbeat is silent this long is lost (default 200;\n"
    "                    the drives are asked for one every 50 ms)\n"
    "  --sdo-timeout MS  wait for each SDO answer at configuration (default 200; one retry)\n"
    "  --enable-timeout MS  each power-state step at enable (default 1000)\n"
    "  --bringup-ms MS   from opening the bus to every drive running at most (default\n"
    "                    20000; many drives, or a slow adapter, may need more)\n"
    "  --log FILE        candump log (candump -l format) of the bus traffic\n"
    "  --trace FILE      CSV: SYNC times, actual positions, targets, segments\n"
    "both:\n"
    "  --fault-reset     reset faulted drives first (default: refuse to enable them)\n"
    "  --machine FILE    machine I/O on GPIO (docs/io.md): e-stop, drive enable, alarms,\n"
    "                    charge pump, M62-M65 outputs, feed hold (--can --mode csp);\n"
    "                    refused while e-stop is active or latched\n"
    "  --params FILE     the machine's LinuxCNC parameter file (work offsets, G28/G30)\n"
    "  --tool-table FILE the machine's LinuxCNC tool table (G43 H lengths, mm)\n"
    "  -v                progress on stderr\n"
    "  smoothing: --tol MM --vmax MM/S --amax MM/S2 --jerk MM/S3 --micro-len MM --g1\n"
    "             --keep-blends\n"
    "             --period-us US --step uniform|corrected (as evenfeed smooth)\n"
    "\n"
    "Exit status 0 when every segment executed; otherwise the negated error code, with\n"
    "the drives told to stop under control.\n";

/* Parse --nodes A[,B[,C...]]: ids 1..127, no repeats, 1..EF_CAN_STREAM_MAX_NODES of them
 * (node k moves axis k: x, y, z, then A B C U V W). */
static int cstrm_nodes(const char *v, ef_can_stream_cfg_t *cc)
{
    if (!*v)
        return cli_error(EF_ERR_ARG, "stream: --nodes needs a list, e.g. 1,2,3");
    char buf[128], *item[EF_CAN_STREAM_MAX_NODES];
    uint8_t ids[EF_CAN_STREAM_MAX_NODES];
    int n = cli_split(v, ',', buf, sizeof buf, item, EF_CAN_STREAM_MAX_NODES);
    if (n > EF_CAN_STREAM_MAX_NODES)
        return cli_error(EF_ERR_ARG, "stream: --nodes '%s': at most %d nodes (x y z a b c u v w)",
                         v, EF_CAN_STREAM_MAX_NODES);
    for (int k = 0; k < n; k++) {
        long long x;
        if (cli_parse_int(item[k], LLONG_MIN, LLONG_MAX, &x) != EF_OK)
            return cli_error(EF_ERR_ARG, "stream: --nodes '%s': node ids separated by commas", v);
        if (x < 1 || x > 127)
            return cli_error(EF_ERR_ARG, "stream: --nodes '%s': node id %lld not 1..127", v, x);
        for (int j = 0; j < k; j++)
            if (ids[j] == x)
                return cli_error(EF_ERR_ARG, "stream: --nodes '%s': node %lld given twice", v, x);
        ids[k] = (uint8_t)x;
    }
    memcpy(cc->nodes, ids, sizeof ids);
    cc->n_nodes = (uint8_t)n;
    return EF_OK;
}

/* Several Modbus drives: ADDRESS=AXES[@UNIT] each; a lone ADDRESS is the X Y Z drive. */
typedef struct {
    const char *arg[EF_MB_MAX_DRIVES]; /* the --modbus values as given */
    int n;
} cstrm_drives_t;

/* Parse the --modbus values into the stream's drive list (unit ids default to --slave). */
static int cstrm_mb_drives(const cstrm_drives_t *dl, ef_mb_stream_cfg_t *c)
{
    for (int k = 0; k < dl->n; k++) {
        char url[512];
        ef_mb_cfg_t d = c->mb; /* timeouts, retries, watchdog, --slave as parsed */
        ef_msg_t m = {{0}};
        snprintf(url, sizeof url, "%s", dl->arg[k]);
        char *eq = strrchr(url, '=');
        if (eq) {
            *eq = '\0';
            char *at = strchr(eq + 1, '@');
            if (at) {
                long long u;
                *at = '\0';
                if (cli_parse_int(at + 1, 1, 247, &u) != EF_OK)
                    return cli_error(EF_ERR_ARG, "stream: --modbus '%s': unit id '%s' not 1..247",
                                     dl->arg[k], at + 1);
                d.slave = (int)u;
            }
            if (ef_mb_axis_parse(eq + 1, &d.axis) != EF_OK)
                return cli_error(EF_ERR_ARG,
                                 "stream: --modbus '%s': axis '%s' unknown (xyz, or one of x y z "
                                 "a b c u v w)",
                                 dl->arg[k], eq + 1);
        } else if (dl->n > 1) {
            return cli_error(EF_ERR_ARG,
                             "stream: --modbus '%s': with several drives each says what it "
                             "carries (ADDRESS=xyz, ADDRESS=a ...)",
                             dl->arg[k]);
        }
        if (ef_mb_url_parse(url, &d, &m) != EF_OK)
            return cli_error(EF_ERR_ARG, "stream: --modbus: %s", m.text);
        c->drives[k] = d;
    }
    c->n_drives = dl->n;
    if (dl->n == 1)
        c->mb = c->drives[0];
    return EF_OK;
}

/* The auxiliary axes the Modbus drives carry (the count from A on; gaps and repeats are
 * the stream's refusals, with the drives named). */
static int cstrm_mb_naux(const ef_mb_stream_cfg_t *c)
{
    int n = 0;
    for (int k = 0; k < c->n_drives; k++)
        n += c->drives[k].axis > 3;
    return n;
}

/* Several Modbus drives: what each executed, and how far apart their clocks ran. */
static void cstrm_mb_report(const ef_mb_stream_cfg_t *c, const ef_mb_stream_result_t *res,
                            int machine)
{
    const ef_mb_stats_t *io = &res->io;
    double span = io->t_last - io->t_first;
    printf("stream: %u segments to %d drives: path time %.3f s, wall time %.3f s, %.0f "
           "segments/s while writing\n",
           res->moves, c->n_drives, res->path_time, res->wall_time,
           span > 0.0 ? (io->slot_writes - 1) / span : 0.0);
    for (int k = 0; k < c->n_drives && k < (int)res->n_drives; k++) {
        const ef_mb_cfg_t *d = &c->drives[k];
        const ef_mb_status_t *st = &res->drive[k];
        const ef_mb_stats_t *di = &res->drive_io[k];
        char where[300];
        if (d->rtu)
            snprintf(where, sizeof where, "rtu:%s slave %d", d->device, d->slave);
        else
            snprintf(where, sizeof where, "tcp://%s:%d", d->host, d->port);
        printf("drive %d %s %s: state %u, fault %u, %u segments executed, following error max "
               "%.4f, %llu transactions, %llu retries, %u duplicate writes acknowledged, %u "
               "writes refused\n",
               k + 1, where, ef_mb_axis_name(d->axis), st->state, st->fault, st->done_count,
               (double)st->ferr_max, (unsigned long long)di->transactions,
               (unsigned long long)di->retries, st->duplicates, st->rejected);
    }
    printf("skew: executed times apart by at most %.0f ms over %u status rounds (bound %.0f "
           "ms)\n",
           res->skew_max_s * 1e3, res->skew_checks, c->skew_max_s * 1e3);
    if (machine)
        printf("machine: %u outputs switched (M62-M65); %u feed holds, %.3f s held\n",
               (unsigned)res->outputs, (unsigned)res->holds, res->held_s);
    fflush(stdout);
}

/* Stream over CAN with the parsed options; print the summary. */
static int cstrm_run_can(const ef_can_stream_cfg_t *cc, const char *path, const cli_machine_t *mc,
                         const ef_gsusb_t *gs)
{
    static ef_gcode_t r; /* about 50 kB: not on the stack */
    ef_msg_t m = {{0}};
    int rc = cli_gcode_open(&r, path, mc);
    if (rc != EF_OK)
        return rc;
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
           "frames (%u dropped by a full receive queue); load %.1f %%, %u error frames\n",
           (unsigned long long)res.tx_frames, (unsigned long long)res.tx_bits, res.bus_time_s,
           cc->bitrate / 1000.0, (unsigned long long)res.rx_frames, (unsigned)res.rx_overrun,
           100.0 * res.load, res.err_frames);
    if (cc->mio)
        printf("machine: %u outputs switched (M62-M65), largest distance from the commanded "
               "point %.4f mm; %u feed holds, %.3f s held\n",
               (unsigned)res.outputs, res.out_err_max, (unsigned)res.holds, res.held_s);
    if (rc == EF_ERR_ESTOP && res.estop_latency_s > 0.0)
        printf("e-stop: line %u, input edge to stop command %.3f ms, to all drives at rest "
               "%.3f ms\n",
               (unsigned)res.estop_line, res.estop_latency_s * 1e3, res.estop_rest_s * 1e3);
    if (gs) {
        ef_gsusb_stats_t st;
        ef_gsusb_stats(gs, &st);
        printf("gs_usb: %llu frames echoed, TX to echo mean %.0f us, min %u us, max %u us; "
               "%u bad IN frames, %u unknown echoes, %u device overflows, %u transfer errors\n",
               (unsigned long long)st.echo.n, ef_gsusb_lat_mean(&st.echo), (unsigned)st.echo.min_us,
               (unsigned)st.echo.max_us, (unsigned)st.bad_frames, (unsigned)st.unknown_echo,
               (unsigned)st.overflow, (unsigned)st.xfer_errors);
        if (st.echo_dev.n)
            printf("gs_usb: on the bus after (device timestamps) mean %.0f us, max %u us, over "
                   "%llu frames\n",
                   ef_gsusb_lat_mean(&st.echo_dev), (unsigned)st.echo_dev.max_us,
                   (unsigned long long)st.echo_dev.n);
    }
    printf("drives:");
    for (int k = 0; k < cc->n_nodes; k++)
        printf("%s node %u \"%s\"", k ? "," : "", (unsigned)cc->nodes[k], res.names[k]);
    printf("; master state %d\n", res.state);
    fflush(stdout);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    return EF_OK;
}

/* Keys of the long options. */
enum {
    O_MODBUS = CLI_LONG,
    O_CAN,
    O_NODES,
    O_CYCLE,
    O_HB,
    O_LOG,
    O_TRACE,
    O_SLAVE,
    O_MODE,
    O_DIRECT_HZ,
    O_TIMEOUT,
    O_RETRIES,
    O_WATCHDOG,
    O_FAULT_RESET,
    O_MACHINE,
    O_SDO,
    O_CAN_OPTS,
    O_BRINGUP,
    O_ENABLE_TO,
    O_SKEW
};

/* Entry point of `evenfeed stream`. */
int cli_cmd_stream(int argc, char **argv)
{
    static const struct option opts[] = {{"modbus", required_argument, NULL, O_MODBUS},
                                         {"can", required_argument, NULL, O_CAN},
                                         {"nodes", required_argument, NULL, O_NODES},
                                         {"cycle-us", required_argument, NULL, O_CYCLE},
                                         {"hb-timeout", required_argument, NULL, O_HB},
                                         {"log", required_argument, NULL, O_LOG},
                                         {"trace", required_argument, NULL, O_TRACE},
                                         {"slave", required_argument, NULL, O_SLAVE},
                                         {"mode", required_argument, NULL, O_MODE},
                                         {"direct-hz", required_argument, NULL, O_DIRECT_HZ},
                                         {"timeout", required_argument, NULL, O_TIMEOUT},
                                         {"retries", required_argument, NULL, O_RETRIES},
                                         {"watchdog", required_argument, NULL, O_WATCHDOG},
                                         {"fault-reset", no_argument, NULL, O_FAULT_RESET},
                                         {"machine", required_argument, NULL, O_MACHINE},
                                         {"sdo-timeout", required_argument, NULL, O_SDO},
                                         {"can-opts", required_argument, NULL, O_CAN_OPTS},
                                         {"bringup-ms", required_argument, NULL, O_BRINGUP},
                                         {"enable-timeout", required_argument, NULL, O_ENABLE_TO},
                                         {"skew-ms", required_argument, NULL, O_SKEW},
                                         CLI_PIPE_OPTIONS,
                                         CLI_MACHINE_OPTIONS,
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, cli_default_table(EF_TABLE_G2_QUINTIC),
                             cli_default_table(EF_TABLE_G1_CUBIC));
    ef_can_stream_cfg_t cc;
    ef_can_stream_cfg_default(&cc, c.pipe.g2, c.pipe.g1);
    const char *path = NULL, *addr = NULL, *iface = NULL, *mode = NULL, *machine = NULL;
    cstrm_drives_t dl = {{NULL}, 0}; /* the --modbus values, parsed once all options are */
    const char *can_opts = NULL;
    int gsusb = 0;
    char mb_only[48] = "", can_only[48] = ""; /* an option of one transport, given */
    ef_msg_t m = {{0}};
    cli_machine_t mc = {0};
    cli_getopt_t g;
    cli_getopt_init(&g, "stream", usage, argc, argv, "v", opts);
    int k;
    while ((k = cli_getopt(&g)) > CLI_END) {
        long long x = 0;
        int rc = EF_OK;
        switch (k) {
        case CLI_HELP:
            return EF_OK;
        case O_MODBUS:
            if (dl.n == EF_MB_MAX_DRIVES)
                return cli_error(EF_ERR_ARG, "stream: --modbus: at most %d drives",
                                 EF_MB_MAX_DRIVES);
            dl.arg[dl.n++] = g.val;
            addr = g.val;
            break;
        case O_SKEW:
            if ((rc = cli_opt_int(&g, 1, 10000, &x)) == EF_OK)
                c.skew_max_s = (double)x * 1e-3;
            break;
        case O_CAN:
            if (!*g.val || *g.val == '-')
                return cli_error(EF_ERR_ARG, "stream: --can needs an interface, e.g. vcan0");
            gsusb = ef_gsusb_spec_is(g.val);
            if (gsusb) {
                char who[64];
                uint32_t rate = 0;
                if (ef_gsusb_spec_parse(g.val, who, sizeof who, &rate, &m) != EF_OK)
                    return cli_error(EF_ERR_ARG, "stream: --can %s", m.text);
                if (rate)
                    cc.bitrate = rate;
            } else if (strlen(g.val) >= 16) /* IFNAMSIZ */
                return cli_error(EF_ERR_ARG, "stream: --can '%s': interface name too long", g.val);
            iface = g.val;
            break;
        case O_NODES:
            rc = cstrm_nodes(g.val, &cc);
            break;
        case O_CYCLE:
            if ((rc = cli_opt_int(&g, 100, 1000000, &x)) == EF_OK)
                cc.cycle_us = (uint32_t)x;
            break;
        case O_CAN_OPTS:
            can_opts = g.val;
            break;
        case O_SDO:
            if ((rc = cli_opt_int(&g, 10, 60000, &x)) == EF_OK)
                cc.sdo_timeout_ms = (uint32_t)x;
            break;
        case O_ENABLE_TO:
            if ((rc = cli_opt_int(&g, 100, 60000, &x)) == EF_OK)
                cc.enable_timeout_ms = (uint32_t)x;
            break;
        case O_BRINGUP:
            if ((rc = cli_opt_int(&g, 1000, 600000, &x)) == EF_OK)
                cc.bringup_ms = (uint32_t)x;
            break;
        case O_HB:
            if ((rc = cli_opt_int(&g, 100, 60000, &x)) == EF_OK)
                cc.hb_timeout_ms = (uint32_t)x;
            break;
        case O_LOG:
            cc.log = g.val;
            break;
        case O_TRACE:
            cc.trace = g.val;
            break;
        case O_SLAVE:
            if ((rc = cli_opt_int(&g, 1, 247, &x)) == EF_OK)
                c.mb.slave = (int)x;
            break;
        case O_MODE:
            if (strcmp(g.val, "segment") && strcmp(g.val, "direct") && strcmp(g.val, "csp"))
                return cli_error(EF_ERR_ARG,
                                 "stream: --mode segment|direct (Modbus), segment|csp (CAN)");
            mode = g.val;
            break;
        case O_DIRECT_HZ:
            if ((rc = cli_opt_int(&g, 1, 10000, &x)) == EF_OK)
                c.direct_hz = (double)x;
            break;
        case O_TIMEOUT:
            if ((rc = cli_opt_int(&g, 1, 60000, &x)) == EF_OK)
                c.mb.timeout_s = (double)x * 1e-3;
            break;
        case O_RETRIES:
            if ((rc = cli_opt_int(&g, 0, 100, &x)) == EF_OK)
                c.mb.retries = (int)x;
            break;
        case O_WATCHDOG:
            if ((rc = cli_opt_int(&g, 0, 65535, &x)) == EF_OK)
                c.mb.watchdog_ms = (uint16_t)x;
            break;
        case O_FAULT_RESET:
            c.fault_reset = 1;
            break;
        case O_MACHINE:
            machine = g.val;
            break;
        case 'v':
            c.verbose = 1;
            break;
        case CLI_ARG:
            if (path)
                return cli_error(EF_ERR_ARG, "stream: one program only ('%s')", g.val);
            path = g.val;
            break;
        default:
            if (!cli_machine_opt(&g, k, &mc))
                rc = cli_pipe_opt(&g, k, &c.pipe);
            break;
        }
        if (rc != EF_OK)
            return rc;
        if (k == O_NODES || k == O_CYCLE || k == O_HB || k == O_LOG || k == O_TRACE || k == O_SDO ||
            k == O_CAN_OPTS || k == O_BRINGUP || k == O_ENABLE_TO)
            snprintf(can_only, sizeof can_only, "%s", g.opt);
        else if (k == O_SLAVE || k == O_DIRECT_HZ || k == O_TIMEOUT || k == O_RETRIES ||
                 k == O_WATCHDOG || k == O_SKEW)
            snprintf(mb_only, sizeof mb_only, "%s", g.opt);
    }
    if (k < 0)
        return k;
    /* The axes are the drives: over CAN one node per axis (--nodes), over Modbus what the
     * listed drives carry (docs/modbus.md). */
    if (addr) {
        int rc = cstrm_mb_drives(&dl, &c);
        if (rc != EF_OK)
            return rc;
    }
    int mb_naux = addr ? cstrm_mb_naux(&c) : 0;
    if (addr && c.pipe.naux > 0 && mb_naux == 0)
        return cli_error(EF_ERR_ARG,
                         "stream: --axes %d: Modbus streaming carries X Y Z only with these "
                         "drives (a program that moves A B C U V W is refused; list a drive per "
                         "auxiliary axis, --modbus ADDRESS=a, docs/modbus.md)",
                         c.pipe.naux + 3);
    if (addr && c.pipe.naux > 0 && c.pipe.naux != mb_naux)
        return cli_error(EF_ERR_ARG,
                         "stream: --axes %d with Modbus drives carrying %d axes: each axis is "
                         "one drive's (or the X Y Z drive's)",
                         c.pipe.naux + 3, mb_naux + 3);
    if (iface && c.pipe.naux > 0 && c.pipe.naux + 3 != cc.n_nodes)
        return cli_error(EF_ERR_ARG,
                         "stream: --axes %d with %u nodes: over CAN each axis is a node (--nodes "
                         "lists x y z a b c u v w in order)",
                         c.pipe.naux + 3, (unsigned)cc.n_nodes);
    if (addr && iface)
        return cli_error(EF_ERR_ARG, "stream: --modbus or --can, not both");
    if ((!addr && !iface) || !path) {
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "stream: %s",
                         !addr && !iface ? "no --modbus address or --can interface" : "no program");
    }
    if (iface && mb_only[0])
        return cli_error(EF_ERR_ARG, "stream: %s is a Modbus option (not with --can)", mb_only);
    if (addr && can_only[0])
        return cli_error(EF_ERR_ARG, "stream: %s is a CAN option (not with --modbus)", can_only);
    if (mode && !strcmp(mode, iface ? "direct" : "csp"))
        return cli_error(EF_ERR_ARG, "stream: --mode %s is not a %s mode (%s)", mode,
                         iface ? "CAN" : "Modbus", iface ? "segment|csp" : "segment|direct");
    if (!c.pipe.g2 || (c.pipe.smooth_degree == 3 && !c.pipe.g1))
        return cli_error(EF_ERR_ARG, "stream: this binary has no built-in tables");
    static ef_mio_t mio; /* the lines stay requested until the process ends */
    if (machine) {
        int rc = cli_mio_open(&mio, machine); /* bad lines: refused before any motion */
        if (rc != EF_OK)
            return rc;
        cc.mio = &mio;
        c.mio = &mio;
    }
    static ef_gsusb_t gs; /* the rings: not on the stack */
    static ef_canif_t gs_ci;
    if (can_opts && !gsusb)
        return cli_error(EF_ERR_ARG, "stream: --can-opts is for gs_usb adapters (--can gsusb...)");
    if (gsusb) {
        ef_gsusb_opts_t go;
        ef_gsusb_init(&gs);
        ef_gsusb_opts_default(&go);
        if (can_opts && ef_gsusb_opts_parse(can_opts, &go, &m) != EF_OK)
            return cli_error(EF_ERR_ARG, "stream: --can-opts: %s", m.text);
        if (ef_gsusb_set_opts(&gs, &go, &m) != EF_OK)
            return cli_error(EF_ERR_ARG, "stream: --can-opts: %s", m.text);
        gs_ci = ef_gsusb_canif(&gs);
        cc.canif = &gs_ci; /* the stream opens it with iface as the name: the whole spec */
    }
    if (iface) {
        /* before the program: name the interface first */
        if (!gsusb && if_nametoindex(iface) == 0)
            return cli_error(EF_ERR_IO, "stream: --can %s: no such network interface", iface);
        cc.iface = iface;
        cc.pipe = c.pipe;
        cc.mode = mode && !strcmp(mode, "csp") ? EF_COM_MODE_CSP : EF_COM_MODE_SEGMENT;
        cc.fault_reset = (uint8_t)c.fault_reset;
        cc.verbose = (uint8_t)c.verbose;
        int rc = cstrm_run_can(&cc, path, &mc, gsusb ? &gs : NULL);
        if (machine)
            ef_mio_close(&mio);
        return rc;
    }
    if (mode)
        c.mode = !strcmp(mode, "direct") ? EF_MB_MODE_DIRECT : EF_MB_MODE_SEGMENT;
    static ef_gcode_t r; /* about 50 kB: not on the stack */
    int rc = cli_gcode_open(&r, path, &mc);
    if (rc != EF_OK)
        return rc;
    static ef_mb_stream_result_t res; /* per-drive statuses: not on the stack */
    rc = ef_mb_stream(&r, &c, &res, &m);
    ef_gcode_free(&r);
    if (c.n_drives > 1) {
        cstrm_mb_report(&c, &res, machine != NULL);
        if (machine)
            ef_mio_close(&mio);
        if (rc != EF_OK)
            return cli_error(rc, "stream: %s", m.text);
        return EF_OK;
    }
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
    if (machine)
        printf("machine: %u outputs switched (M62-M65); %u feed holds, %.3f s held\n",
               (unsigned)res.outputs, (unsigned)res.holds, res.held_s);
    fflush(stdout);
    if (machine)
        ef_mio_close(&mio);
    if (rc != EF_OK)
        return cli_error(rc, "stream: %s", m.text);
    return EF_OK;
}
