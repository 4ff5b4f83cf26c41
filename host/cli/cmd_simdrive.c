/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed sim-drive: a simulated drive for tests and demos (docs/modbus.md). */
#include <signal.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/modbus/ef_mb.h"

static const char usage[] =
    "usage: evenfeed sim-drive modbus (--tcp HOST:PORT | --rtu DEVICE[,BAUD[,8N1]]) [options]\n"
    "       evenfeed sim-drive can --iface IFACE --node N [options]\n"
    "\n"
    "A simulated evenfeed Modbus drive (3 axes, or one: docs/modbus.md): executes streamed\n"
    "segments through a servo model. Prints 'ready tcp HOST:PORT' (the port actually bound;\n"
    "give port 0 for any free one) or 'ready rtu DEVICE' once it accepts requests, and runs\n"
    "until SIGTERM or SIGINT.\n"
    "\n"
    "  --axes 1|3           axes per segment slot: 3 an X Y Z drive (default), 1 a\n"
    "                       single-axis drive (its axis is the trace's x)\n"
    "  --slave N            unit id / slave address (default 1)\n"
    "  --trace FILE         CSV of every servo period while enabled, plus '#' lines for\n"
    "                       accepted segments and injected faults\n"
    "  --time-scale K       drive time runs K times faster than wall time (default 1)\n"
    "  --home X,Y,Z         position at power-up (default 0,0,0; --axes 1: --home X)\n"
    "  --ferr-limit MM      following error that faults (default 1)\n"
    "  --wire-baud B        RTU: hold each reply for its frames' time on a B baud line\n"
    "fault injection (each once):\n"
    "  --exception-at SEQ[:CODE]  answer the write of segment SEQ with exception CODE (4)\n"
    "  --drop-reply-at SEQ  execute segment SEQ's write but send no reply\n"
    "  --disconnect-at SEQ  execute segment SEQ's write, then drop the connection\n"
    "  --fault-at SEC       raise a drive fault at drive time SEC\n"
    "the drive's own I/O on GPIO (docs/io.md), CHIP:LINE or a line name on gpiochip0:\n"
    "  --sto LINE           hardware enable (safe torque off) input: while it reads 0\n"
    "                       the power stage may not be on (drive fault 6 when it is)\n"
    "  --alarm-out LINE     alarm output: 1 while the drive is in fault, and on exit\n"
    "\n"
    "A simulated CANopen CiA 402 drive (one axis, docs/can.md) on a SocketCAN interface:\n"
    "CSP and evenfeed segment mode through the same servo model. Prints\n"
    "'ready can NODE IFACE' once its socket is open, and runs until SIGTERM or SIGINT.\n"
    "\n"
    "  --iface IFACE        CAN interface, e.g. vcan0 (required)\n"
    "  --node N             node id 1..127 (required)\n"
    "  --home X             position at power-up (default 0)\n"
    "  --trace FILE         CSV: each SYNC step, accepted segments, EMCYs\n"
    "  --log FILE           candump log of what the drive receives and sends\n"
    "  --run-ms MS          stop after MS ms of wall time (default: run until a signal)\n"
    "  --sync-timeout MS    SYNC-loss watchdog 0x2003 at power-up (default 500; 0 off)\n"
    "the drive's own I/O on GPIO (docs/io.md), CHIP:LINE or a line name on gpiochip0:\n"
    "  --sto LINE           hardware enable (safe torque off) input: while it reads 0\n"
    "                       the power stage may not be on (EMCY 0xFF06 when it is)\n"
    "  --alarm-out LINE     alarm output: 1 while the drive is in fault, and on exit\n"
    "fault injection, at SYNC time in OPERATION ENABLED (SYNCs x cycle period), each once:\n"
    "  --fault-at MS        raise drive fault 4 (EMCY 0xFF04)\n"
    "  --hb-stop-at MS      stop sending heartbeats\n"
    "  --bus-off-at MS      send a bus-off error frame\n"
    "  --drop-rx K[,K..]    drop the K-th (1-based) segment chunk frame received\n";

static volatile sig_atomic_t csd_stop;

/* SIGTERM/SIGINT end the server loop. */
static void csd_on_signal(int sig)
{
    (void)sig;
    csd_stop = 1;
}

/* Stop on SIGTERM and SIGINT (csd_stop). */
static void csd_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = csd_on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
}

/* Parse --drop-rx K[,K..]: 1-based chunk counts. */
static int csd_drops(const char *v, ef_can_sim_cfg_t *c)
{
    char buf[512], *item[EF_CAN_SIM_MAX_DROPS];
    int n = *v ? cli_split(v, ',', buf, sizeof buf, item, EF_CAN_SIM_MAX_DROPS) : 0;
    if (n == 0)
        return cli_error(EF_ERR_ARG, "sim-drive: --drop-rx needs K[,K..]");
    if (n > EF_CAN_SIM_MAX_DROPS)
        return cli_error(EF_ERR_ARG, "sim-drive: --drop-rx: at most %d entries",
                         EF_CAN_SIM_MAX_DROPS);
    for (int k = 0; k < n; k++) {
        long long x;
        if (cli_parse_int(item[k], 1, 0x7fffffffL, &x) != EF_OK)
            return cli_error(EF_ERR_ARG,
                             "sim-drive: --drop-rx '%s': whole numbers >= 1, comma separated", v);
        c->drop_rx[k] = (uint32_t)x;
    }
    c->n_drop = (uint32_t)n;
    return EF_OK;
}

/* Keys of the long options (both buses). */
enum {
    O_IFACE = CLI_LONG,
    O_NODE,
    O_HOME,
    O_TRACE,
    O_LOG,
    O_RUN_MS,
    O_FAULT_AT,
    O_HB_STOP_AT,
    O_BUS_OFF_AT,
    O_DROP_RX,
    O_TCP,
    O_RTU,
    O_SLAVE,
    O_TIME_SCALE,
    O_FERR_LIMIT,
    O_WIRE_BAUD,
    O_EXCEPTION_AT,
    O_DROP_REPLY_AT,
    O_DISCONNECT_AT,
    O_SYNC_TIMEOUT,
    O_STO,
    O_ALARM_OUT,
    O_AXES
};

/* `evenfeed sim-drive can`: one simulated CANopen drive. */
static int csd_can(int argc, char **argv)
{
    static const struct option opts[] = {{"iface", required_argument, NULL, O_IFACE},
                                         {"node", required_argument, NULL, O_NODE},
                                         {"home", required_argument, NULL, O_HOME},
                                         {"trace", required_argument, NULL, O_TRACE},
                                         {"log", required_argument, NULL, O_LOG},
                                         {"run-ms", required_argument, NULL, O_RUN_MS},
                                         {"fault-at", required_argument, NULL, O_FAULT_AT},
                                         {"hb-stop-at", required_argument, NULL, O_HB_STOP_AT},
                                         {"bus-off-at", required_argument, NULL, O_BUS_OFF_AT},
                                         {"drop-rx", required_argument, NULL, O_DROP_RX},
                                         {"sync-timeout", required_argument, NULL, O_SYNC_TIMEOUT},
                                         {"sto", required_argument, NULL, O_STO},
                                         {"alarm-out", required_argument, NULL, O_ALARM_OUT},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    ef_can_sim_cfg_t c;
    ef_can_sim_cfg_default(&c);
    ef_msg_t m = {{0}};
    int have_node = 0, k;
    cli_getopt_t g;
    cli_getopt_init(&g, "sim-drive", usage, argc, argv, "", opts);
    while ((k = cli_getopt(&g)) > CLI_END) {
        long long x = 0;
        double d;
        int rc = EF_OK;
        switch (k) {
        case CLI_HELP:
            return EF_OK;
        case O_IFACE:
            if (!*g.val || *g.val == '-' || strlen(g.val) >= 16)
                return cli_error(EF_ERR_ARG, "sim-drive: --iface needs an interface name "
                                             "(at most 15 characters)");
            c.iface = g.val;
            break;
        case O_NODE:
            if ((rc = cli_opt_int(&g, 1, 127, &x)) == EF_OK) {
                c.node = (uint8_t)x;
                have_node = 1;
            }
            break;
        case O_HOME:
            if (cli_parse_double(g.val, &d) != EF_OK || !(d >= -1e6 && d <= 1e6))
                return cli_error(EF_ERR_ARG, "sim-drive: --home X: a position within +-1e6");
            c.home = (float)d;
            break;
        case O_TRACE:
            c.trace = g.val;
            break;
        case O_LOG:
            c.log = g.val;
            break;
        case O_RUN_MS:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.run_ms = (long)x;
            break;
        case O_FAULT_AT:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.fault_at_ms = (long)x;
            break;
        case O_HB_STOP_AT:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.hb_stop_at_ms = (long)x;
            break;
        case O_BUS_OFF_AT:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.bus_off_at_ms = (long)x;
            break;
        case O_DROP_RX:
            rc = csd_drops(g.val, &c);
            break;
        case O_SYNC_TIMEOUT:
            if ((rc = cli_opt_int(&g, 0, 60000, &x)) == EF_OK)
                c.sync_timeout_ms = (long)x;
            break;
        case O_STO:
            c.sto_line = g.val;
            break;
        case O_ALARM_OUT:
            c.alarm_line = g.val;
            break;
        default: /* CLI_ARG */
            return cli_error(EF_ERR_ARG, "sim-drive: unknown option '%s'", g.val);
        }
        if (rc != EF_OK)
            return rc;
    }
    if (k < 0)
        return k;
    if (!c.iface || !have_node)
        return cli_error(EF_ERR_ARG, "sim-drive: can needs --iface IFACE and --node N");
    csd_signals();
    c.stop = &csd_stop;
    int rc = ef_can_sim_run(&c, &m);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    return EF_OK;
}

/* Parse --home X,Y,Z, or --home X (a single-axis drive's; y and z 0). */
static int csd_home3(const char *v, float home[3])
{
    char buf[256], *item[3];
    double h[3] = {0.0, 0.0, 0.0};
    int n = cli_split(v, ',', buf, sizeof buf, item, 3);
    if (n != 1 && n != 3)
        return cli_error(EF_ERR_ARG, "sim-drive: --home X,Y,Z (or X for --axes 1)");
    for (int i = 0; i < n; i++)
        if (cli_parse_double(item[i], &h[i]) != EF_OK || !(h[i] >= -1e6 && h[i] <= 1e6))
            return cli_error(EF_ERR_ARG, "sim-drive: --home X,Y,Z: positions within +-1e6");
    for (int i = 0; i < 3; i++)
        home[i] = (float)h[i];
    return EF_OK;
}

/* Parse --exception-at SEQ[:CODE]. */
static int csd_exception(const char *v, ef_mb_server_cfg_t *c)
{
    char buf[64], *item[2];
    long long seq, code = EF_MB_EX_DEVICE_FAILURE;
    int n = cli_split(v, ':', buf, sizeof buf, item, 2);
    if (n < 1 || n > 2 || cli_parse_int(item[0], 0, 0x7fffffffL, &seq) != EF_OK ||
        (n == 2 && cli_parse_int(item[1], 1, 11, &code) != EF_OK))
        return cli_error(EF_ERR_ARG, "sim-drive: --exception-at SEQ[:CODE 1..11]");
    c->exception_seq = (long)seq;
    c->exception_code = (int)code;
    return EF_OK;
}

/* `evenfeed sim-drive modbus`: one simulated Modbus drive. */
static int csd_modbus(int argc, char **argv)
{
    static const struct option opts[] = {
        {"tcp", required_argument, NULL, O_TCP},
        {"rtu", required_argument, NULL, O_RTU},
        {"slave", required_argument, NULL, O_SLAVE},
        {"trace", required_argument, NULL, O_TRACE},
        {"time-scale", required_argument, NULL, O_TIME_SCALE},
        {"ferr-limit", required_argument, NULL, O_FERR_LIMIT},
        {"home", required_argument, NULL, O_HOME},
        {"wire-baud", required_argument, NULL, O_WIRE_BAUD},
        {"exception-at", required_argument, NULL, O_EXCEPTION_AT},
        {"drop-reply-at", required_argument, NULL, O_DROP_REPLY_AT},
        {"disconnect-at", required_argument, NULL, O_DISCONNECT_AT},
        {"fault-at", required_argument, NULL, O_FAULT_AT},
        {"sto", required_argument, NULL, O_STO},
        {"alarm-out", required_argument, NULL, O_ALARM_OUT},
        {"axes", required_argument, NULL, O_AXES},
        CLI_OPT_HELP,
        CLI_OPT_END};
    ef_mb_server_cfg_t c;
    ef_mb_server_cfg_default(&c);
    ef_msg_t m = {{0}};
    int have_addr = 0, k;
    cli_getopt_t g;
    cli_getopt_init(&g, "sim-drive", usage, argc, argv, "", opts);
    while ((k = cli_getopt(&g)) > CLI_END) {
        long long x = 0;
        double d;
        int rc = EF_OK;
        switch (k) {
        case CLI_HELP:
            return EF_OK;
        case O_TCP:
        case O_RTU: {
            char url[300];
            snprintf(url, sizeof url, "%s%s", k == O_TCP ? "tcp://" : "rtu:", g.val);
            if (ef_mb_url_parse(url, &c.mb, &m) != EF_OK)
                return cli_error(EF_ERR_ARG, "sim-drive: %s", m.text);
            have_addr = 1;
            break;
        }
        case O_SLAVE:
            if ((rc = cli_opt_int(&g, 1, 247, &x)) == EF_OK)
                c.mb.slave = (int)x;
            break;
        case O_AXES:
            if (strcmp(g.val, "1") && strcmp(g.val, "3"))
                return cli_error(EF_ERR_ARG, "sim-drive: --axes '%s': 1 or 3", g.val);
            c.axes = g.val[0] - '0';
            break;
        case O_TRACE:
            c.trace = g.val;
            break;
        case O_TIME_SCALE:
            if (cli_parse_double(g.val, &d) != EF_OK || !(d >= 0.01 && d <= 1000.0))
                return cli_error(EF_ERR_ARG, "sim-drive: --time-scale 0.01..1000");
            c.time_scale = d;
            break;
        case O_FERR_LIMIT:
            if (cli_parse_double(g.val, &d) != EF_OK || !(d > 0.0))
                return cli_error(EF_ERR_ARG, "sim-drive: --ferr-limit must be > 0");
            c.servo.ferr_lim = (float)d;
            break;
        case O_HOME:
            rc = csd_home3(g.val, c.home);
            break;
        case O_WIRE_BAUD:
            if ((rc = cli_opt_int(&g, 0, 4000000, &x)) == EF_OK)
                c.wire_baud = (int)x;
            break;
        case O_EXCEPTION_AT:
            rc = csd_exception(g.val, &c);
            break;
        case O_DROP_REPLY_AT:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.drop_reply_seq = (long)x;
            break;
        case O_DISCONNECT_AT:
            if ((rc = cli_opt_int(&g, 0, 0x7fffffffL, &x)) == EF_OK)
                c.disconnect_seq = (long)x;
            break;
        case O_FAULT_AT:
            if (cli_parse_double(g.val, &d) != EF_OK || !(d >= 0.0))
                return cli_error(EF_ERR_ARG, "sim-drive: --fault-at needs seconds >= 0");
            c.fault_at_s = d;
            break;
        case O_STO:
            c.sto_line = g.val;
            break;
        case O_ALARM_OUT:
            c.alarm_line = g.val;
            break;
        default: /* CLI_ARG */
            return cli_error(EF_ERR_ARG, "sim-drive: unknown option '%s'", g.val);
        }
        if (rc != EF_OK)
            return rc;
    }
    if (k < 0)
        return k;
    if (!have_addr)
        return cli_error(EF_ERR_ARG, "sim-drive: give --tcp HOST:PORT or --rtu DEVICE");
    if (c.axes == 1 && (c.home[1] != 0.0f || c.home[2] != 0.0f))
        return cli_error(EF_ERR_ARG, "sim-drive: --axes 1: --home X (one axis; y and z 0)");
    csd_signals();
    signal(SIGPIPE, SIG_IGN); /* a client that vanishes must not kill the drive */
    c.stop = &csd_stop;
    int rc = ef_mb_serve(&c, &m);
    if (rc != EF_OK)
        return cli_error(rc, "sim-drive: %s", m.text);
    return EF_OK;
}

static const cli_cmd_t csd_buses[] = {
    {"modbus", csd_modbus, "a Modbus drive (3 axes, or one) on TCP or RTU"},
    {"can", csd_can, "a CANopen CiA 402 drive (one axis) on a SocketCAN interface"},
    {NULL, NULL, NULL}};

/* Entry point of `evenfeed sim-drive`. */
int cli_cmd_sim_drive(int argc, char **argv)
{
    if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        fputs(usage, stdout);
        return EF_OK;
    }
    const cli_cmd_t *bus = argc >= 2 ? cli_cmd_find(csd_buses, argv[1]) : NULL;
    if (!bus) {
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "sim-drive: bus '%s' is not supported (modbus, can)",
                         argc >= 2 ? argv[1] : "");
    }
    return bus->fn(argc - 1, argv + 1);
}
