/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed sim-drive: a simulated drive for tests and demos (docs/modbus.md). */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/modbus/ef_mb.h"

static const char usage[] =
    "usage: evenfeed sim-drive modbus (--tcp HOST:PORT | --rtu DEVICE[,BAUD[,8N1]]) [options]\n"
    "       evenfeed sim-drive can --iface IFACE --node N [options]\n"
    "\n"
    "A simulated evenfeed Modbus drive (3 axes, docs/modbus.md): executes streamed\n"
    "segments through a servo model. Prints 'ready tcp HOST:PORT' (the port actually bound;\n"
    "give port 0 for any free one) or 'ready rtu DEVICE' once it accepts requests, and runs\n"
    "until SIGTERM or SIGINT.\n"
    "\n"
    "  --slave N            unit id / slave address (default 1)\n"
    "  --trace FILE         CSV of every servo period while enabled, plus '#' lines for\n"
    "                       accepted segments and injected faults\n"
    "  --time-scale K       drive time runs K times faster than wall time (default 1)\n"
    "  --home X,Y,Z         position at power-up (default 0,0,0)\n"
    "  --ferr-limit MM      following error that faults (default 1)\n"
    "  --wire-baud B        RTU: hold each reply for its frames' time on a B baud line\n"
    "fault injection (each once):\n"
    "  --exception-at SEQ[:CODE]  answer the write of segment SEQ with exception CODE (4)\n"
    "  --drop-reply-at SEQ  execute segment SEQ's write but send no reply\n"
    "  --disconnect-at SEQ  execute segment SEQ's write, then drop the connection\n"
    "  --fault-at SEC       raise a drive fault at drive time SEC\n"
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
    "fault injection, at SYNC time in OPERATION ENABLED (SYNCs x cycle period), each once:\n"
    "  --fault-at MS        raise drive fault 4 (EMCY 0xFF04)\n"
    "  --hb-stop-at MS      stop sending heartbeats\n"
    "  --bus-off-at MS      send a bus-off error frame\n"
    "  --drop-rx K[,K..]    drop the K-th (1-based) segment chunk frame received\n";

static volatile sig_atomic_t sd_stop;

/* SIGTERM/SIGINT end the server loop. */
static void sd_on_signal(int sig)
{
    (void)sig;
    sd_stop = 1;
}

/* Parse a nonnegative whole number. */
static int sd_long(const char *opt, const char *v, long hi, long *out)
{
    char *end;
    if (!v)
        return ef_cli_error(EF_ERR_ARG, "sim-drive: %s needs a value", opt);
    long x = strtol(v, &end, 10);
    if (end == v || *end || x < 0 || x > hi)
        return ef_cli_error(EF_ERR_ARG, "sim-drive: %s '%s': a whole number 0..%ld", opt, v, hi);
    *out = x;
    return 0;
}

/* Parse a milliseconds option of sim-drive can (0 .. 2^31 - 1). */
static int sd_ms(const char *opt, const char *v, long *out)
{
    return sd_long(opt, v, 0x7fffffffL, out);
}

/* Parse --drop-rx K[,K..]: 1-based chunk counts. */
static int sd_drops(const char *v, ef_can_sim_cfg_t *c)
{
    if (!v || !*v)
        return ef_cli_error(EF_ERR_ARG, "sim-drive: --drop-rx needs K[,K..]");
    const char *p = v;
    c->n_drop = 0;
    for (;;) {
        char *end;
        long x = strtol(p, &end, 10);
        if (end == p || (*end && *end != ',') || x < 1 || x > 0x7fffffffL)
            return ef_cli_error(
                EF_ERR_ARG, "sim-drive: --drop-rx '%s': whole numbers >= 1, comma separated", v);
        if (c->n_drop >= EF_CAN_SIM_MAX_DROPS)
            return ef_cli_error(EF_ERR_ARG, "sim-drive: --drop-rx: at most %d entries",
                                EF_CAN_SIM_MAX_DROPS);
        c->drop_rx[c->n_drop++] = (uint32_t)x;
        if (!*end)
            return 0;
        p = end + 1;
    }
}

/* `evenfeed sim-drive can`: one simulated CANopen drive. */
static int sd_can(int argc, char **argv)
{
    ef_can_sim_cfg_t c;
    ef_can_sim_cfg_default(&c);
    ef_msg_t m = {{0}};
    int have_node = 0;
    for (int k = 2; k < argc; k++) {
        const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;
        long x = 0;
        double d;
        int rc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--iface")) {
            if (!v || !*v || *v == '-' || strlen(v) >= 16)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --iface needs an interface name "
                                                "(at most 15 characters)");
            c.iface = v;
            k++;
        } else if (!strcmp(a, "--node")) {
            char *end;
            x = v ? strtol(v, &end, 10) : 0;
            if (!v || end == v || *end || x < 1 || x > 127)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --node '%s': a node id 1..127",
                                    v ? v : "");
            c.node = (uint8_t)x;
            have_node = 1;
            k++;
        } else if (!strcmp(a, "--home")) {
            if (!v || ef_cli_double(a, v, &d) || !(d >= -1e6 && d <= 1e6))
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --home X: a position within +-1e6");
            c.home = (float)d;
            k++;
        } else if (!strcmp(a, "--trace") || !strcmp(a, "--log")) {
            if (!v)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: %s needs a file name", a);
            if (a[2] == 't')
                c.trace = v;
            else
                c.log = v;
            k++;
        } else if (!strcmp(a, "--run-ms")) {
            if ((rc = sd_ms(a, v, &x)))
                return rc;
            c.run_ms = x;
            k++;
        } else if (!strcmp(a, "--fault-at") || !strcmp(a, "--hb-stop-at") ||
                   !strcmp(a, "--bus-off-at")) {
            if ((rc = sd_ms(a, v, &x)))
                return rc;
            if (a[2] == 'f')
                c.fault_at_ms = x;
            else if (a[2] == 'h')
                c.hb_stop_at_ms = x;
            else
                c.bus_off_at_ms = x;
            k++;
        } else if (!strcmp(a, "--drop-rx")) {
            if ((rc = sd_drops(v, &c)))
                return rc;
            k++;
        } else {
            return ef_cli_error(EF_ERR_ARG, "sim-drive: unknown option '%s'", a);
        }
    }
    if (!c.iface || !have_node)
        return ef_cli_error(EF_ERR_ARG, "sim-drive: can needs --iface IFACE and --node N");
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = sd_on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    c.stop = &sd_stop;
    int rc = ef_can_sim_run(&c, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    return 0;
}

/* Entry point of `evenfeed sim-drive`. */
int ef_cmd_sim_drive(int argc, char **argv)
{
    if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        fputs(usage, stdout);
        return 0;
    }
    if (argc >= 2 && !strcmp(argv[1], "can"))
        return sd_can(argc, argv);
    if (argc < 2 || strcmp(argv[1], "modbus") != 0) {
        fputs(usage, stderr);
        return ef_cli_error(EF_ERR_ARG, "sim-drive: bus '%s' is not supported (modbus, can)",
                            argc >= 2 ? argv[1] : "");
    }
    ef_mb_server_cfg_t c;
    ef_mb_server_cfg_default(&c);
    ef_msg_t m = {{0}};
    int have_addr = 0;
    for (int k = 2; k < argc; k++) {
        const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;
        long x = 0;
        double d;
        int rc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--tcp") || !strcmp(a, "--rtu")) {
            char url[300];
            if (!v)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: %s needs an address", a);
            snprintf(url, sizeof url, "%s%s", a[2] == 't' ? "tcp://" : "rtu:", v);
            if (ef_mb_url_parse(url, &c.mb, &m) != EF_OK)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: %s", m.text);
            have_addr = 1;
            k++;
        } else if (!strcmp(a, "--slave")) {
            if ((rc = sd_long(a, v, 247, &x)))
                return rc;
            if (x < 1)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --slave 1..247");
            c.mb.slave = (int)x;
            k++;
        } else if (!strcmp(a, "--trace")) {
            if (!v)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --trace needs a file name");
            c.trace = v;
            k++;
        } else if (!strcmp(a, "--time-scale")) {
            if (!v || ef_cli_double(a, v, &d) || !(d >= 0.01 && d <= 1000.0))
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --time-scale 0.01..1000");
            c.time_scale = d;
            k++;
        } else if (!strcmp(a, "--ferr-limit")) {
            if (!v || ef_cli_double(a, v, &d) || !(d > 0.0))
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --ferr-limit must be > 0");
            c.servo.ferr_lim = (float)d;
            k++;
        } else if (!strcmp(a, "--home")) {
            double h[3];
            if (!v || sscanf(v, "%lf,%lf,%lf", &h[0], &h[1], &h[2]) != 3)
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --home X,Y,Z");
            for (int i = 0; i < 3; i++)
                c.home[i] = (float)h[i];
            k++;
        } else if (!strcmp(a, "--wire-baud")) {
            if ((rc = sd_long(a, v, 4000000, &x)))
                return rc;
            c.wire_baud = (int)x;
            k++;
        } else if (!strcmp(a, "--exception-at")) {
            long code = EF_MB_EX_DEVICE_FAILURE;
            char *end;
            x = v ? strtol(v, &end, 10) : -1;
            if (!v || end == v || x < 0 ||
                (*end &&
                 (*end != ':' || (code = strtol(end + 1, &end, 10)) < 1 || code > 11 || *end)))
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --exception-at SEQ[:CODE 1..11]");
            c.exception_seq = x;
            c.exception_code = (int)code;
            k++;
        } else if (!strcmp(a, "--drop-reply-at")) {
            if ((rc = sd_long(a, v, 0x7fffffffL, &x)))
                return rc;
            c.drop_reply_seq = x;
            k++;
        } else if (!strcmp(a, "--disconnect-at")) {
            if ((rc = sd_long(a, v, 0x7fffffffL, &x)))
                return rc;
            c.disconnect_seq = x;
            k++;
        } else if (!strcmp(a, "--fault-at")) {
            if (!v || ef_cli_double(a, v, &d) || !(d >= 0.0))
                return ef_cli_error(EF_ERR_ARG, "sim-drive: --fault-at needs seconds >= 0");
            c.fault_at_s = d;
            k++;
        } else {
            return ef_cli_error(EF_ERR_ARG, "sim-drive: unknown option '%s'", a);
        }
    }
    if (!have_addr)
        return ef_cli_error(EF_ERR_ARG, "sim-drive: give --tcp HOST:PORT or --rtu DEVICE");
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = sd_on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN); /* a client that vanishes must not kill the drive */
    c.stop = &sd_stop;
    int rc = ef_mb_serve(&c, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "sim-drive: %s", m.text);
    return 0;
}
