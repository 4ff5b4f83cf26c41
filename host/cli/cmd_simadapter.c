/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed sim-adapter: a simulated USB-CAN adapter on a real USB bus (docs/can.md). */
#include <signal.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_gsusb_sim.h"

static const char usage[] =
    "usage: evenfeed sim-adapter gsusb --iface IFACE[,IFACE..] [options]\n"
    "\n"
    "A simulated gs_usb USB-CAN adapter (candleLight firmware on an STM32F072): a USB\n"
    "gadget made through configfs and FunctionFS, bound to a UDC (dummy_hcd: the host's\n"
    "own USB bus), bridging to SocketCAN interfaces. The kernel's gs_usb driver or\n"
    "`evenfeed can --gsusb` drive it like the real adapter (docs/can.md). Needs root,\n"
    "configfs at /sys/kernel/config, FunctionFS and a UDC. Prints\n"
    "'ready gs_usb serial=S udc=U' once the host has configured it, and runs until\n"
    "SIGTERM or SIGINT, then removes the gadget.\n"
    "\n"
    "  --iface IFACE[,..]   CAN interface of each channel (one: all channels share it)\n"
    "  --serial S           USB serial number (default EF0000000001)\n"
    "  --vid-pid V:P        USB ids in hex (default 1d50:606f, candleLight)\n"
    "  --clock HZ           CAN clock BT_CONST reports (default 48000000)\n"
    "  --channels N         channels, 1..8 (default 1; Linux's gs_usb takes 3)\n"
    "  --ts-start US        timestamp counter at start, 0..4294967295 (default 0)\n"
    "  --udc NAME           UDC to bind to (default: the first of /sys/class/udc)\n"
    "  --name GADGET        configfs gadget and FunctionFS name (default ef_gsusb)\n"
    "  --no-pace            send frames at once, not at the bitrate's pace\n"
    "  --verbose            log requests, mode changes and counters on stderr\n"
    "fault injection (repeatable):\n"
    "  --fault short-reply  BT_CONST answered with 20 of 40 bytes\n"
    "  --fault long-reply   DEVICE_CONFIG answered with the whole wLength (junk after 12)\n"
    "  --fault bad-frame    every 50th frame to the host is 19 bytes\n"
    "  --fault bad-channel  received frames carry channel 5\n"
    "  --fault stall-in[=N] halt the IN endpoint once after N frames (default 10)\n"
    "  --fault no-echo      never echo sent frames (the host's TX window fills)\n"
    "  --fault no-answer    never answer control requests (the host times out)\n"
    "  --fault bitrate-max=N  refuse bit timings above N bit/s\n"
    "  --fault bus-off      report bus-off (an error frame) after 300 received frames\n"
    "  --fault overflow     flag every 300th received frame OVERFLOW (frames lost)\n";

static volatile sig_atomic_t csa_stop;

/* SIGTERM/SIGINT end the adapter. */
static void csa_on_signal(int sig)
{
    (void)sig;
    csa_stop = 1;
}

/* Parse --iface IFACE[,IFACE..] into c->iface (names point into buf, which must live). */
static int csa_ifaces(const char *v, char *buf, size_t size, ef_gsusb_sim_cfg_t *c)
{
    char *item[EF_GSUSB_SIM_MAX_IFACES];
    int n = cli_split(v, ',', buf, size, item, EF_GSUSB_SIM_MAX_IFACES);
    if (n < 1 || n > (int)EF_GSUSB_SIM_MAX_IFACES)
        return cli_error(EF_ERR_ARG, "sim-adapter: --iface: 1..%u interface names",
                         EF_GSUSB_SIM_MAX_IFACES);
    for (int k = 0; k < n; k++) {
        if (!*item[k] || *item[k] == '-' || strlen(item[k]) >= 16)
            return cli_error(EF_ERR_ARG,
                             "sim-adapter: --iface '%s': interface names of 1..15 "
                             "characters, comma separated",
                             v);
        c->iface[k] = item[k];
    }
    c->n_iface = (unsigned)n;
    return EF_OK;
}

/* Parse --vid-pid V:P (hex, 0x optional). */
static int csa_vidpid(const char *v, ef_gsusb_sim_cfg_t *c)
{
    unsigned vid, pid;
    char tail;
    if (sscanf(v, "%x:%x%c", &vid, &pid, &tail) != 2 || vid > 0xffff || pid > 0xffff ||
        v[0] == '-' || !strchr(v, ':') || strchr(v, ':')[1] == '-')
        return cli_error(EF_ERR_ARG, "sim-adapter: --vid-pid '%s': V:P, 16-bit hex numbers", v);
    c->vid = (uint16_t)vid;
    c->pid = (uint16_t)pid;
    return EF_OK;
}

/* Keys of the long options. */
enum {
    O_IFACE = CLI_LONG,
    O_SERIAL,
    O_VIDPID,
    O_CLOCK,
    O_CHANNELS,
    O_TS_START,
    O_UDC,
    O_NAME,
    O_NO_PACE,
    O_FAULT,
    O_VERBOSE
};

/* `evenfeed sim-adapter gsusb`. */
static int csa_gsusb(int argc, char **argv)
{
    static const struct option opts[] = {{"iface", required_argument, NULL, O_IFACE},
                                         {"serial", required_argument, NULL, O_SERIAL},
                                         {"vid-pid", required_argument, NULL, O_VIDPID},
                                         {"clock", required_argument, NULL, O_CLOCK},
                                         {"channels", required_argument, NULL, O_CHANNELS},
                                         {"ts-start", required_argument, NULL, O_TS_START},
                                         {"udc", required_argument, NULL, O_UDC},
                                         {"name", required_argument, NULL, O_NAME},
                                         {"no-pace", no_argument, NULL, O_NO_PACE},
                                         {"fault", required_argument, NULL, O_FAULT},
                                         {"verbose", no_argument, NULL, O_VERBOSE},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    static char ifbuf[256];
    ef_gsusb_sim_cfg_t c;
    ef_gsusb_sim_cfg_default(&c);
    ef_msg_t m = {{0}};
    int k;
    cli_getopt_t g;
    cli_getopt_init(&g, "sim-adapter", usage, argc, argv, "", opts);
    while ((k = cli_getopt(&g)) > CLI_END) {
        long long x = 0;
        int rc = EF_OK;
        switch (k) {
        case CLI_HELP:
            return EF_OK;
        case O_IFACE:
            rc = csa_ifaces(g.val, ifbuf, sizeof ifbuf, &c);
            break;
        case O_SERIAL:
            if (!*g.val || strlen(g.val) > 63)
                return cli_error(EF_ERR_ARG, "sim-adapter: --serial: 1..63 characters");
            c.serial = g.val;
            break;
        case O_VIDPID:
            rc = csa_vidpid(g.val, &c);
            break;
        case O_CLOCK:
            if ((rc = cli_opt_int(&g, 1000000, 1000000000, &x)) == EF_OK)
                c.fclk = (uint32_t)x;
            break;
        case O_CHANNELS:
            if ((rc = cli_opt_int(&g, 1, EF_GSUSB_MAX_CHANNELS, &x)) == EF_OK)
                c.channels = (uint8_t)x;
            break;
        case O_TS_START:
            if ((rc = cli_opt_int(&g, 0, 0xffffffffLL, &x)) == EF_OK)
                c.ts_start = (uint32_t)x;
            break;
        case O_UDC:
            c.udc = g.val;
            break;
        case O_NAME:
            c.name = g.val;
            break;
        case O_NO_PACE:
            c.pace = 0;
            break;
        case O_FAULT:
            if (ef_gsusb_sim_fault(&c, g.val, &m) != EF_OK)
                return cli_error(EF_ERR_ARG, "sim-adapter: --fault: %s", m.text);
            break;
        case O_VERBOSE:
            c.verbose = 1;
            break;
        default: /* CLI_ARG */
            return cli_error(EF_ERR_ARG, "sim-adapter: unknown option '%s'", g.val);
        }
        if (rc != EF_OK)
            return rc;
    }
    if (k < 0)
        return k;
    if (c.n_iface == 0)
        return cli_error(EF_ERR_ARG, "sim-adapter: gsusb needs --iface IFACE");
    if (c.n_iface > c.channels)
        return cli_error(EF_ERR_ARG, "sim-adapter: %u interfaces for %u channels (--channels)",
                         c.n_iface, c.channels);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = csa_on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    c.stop = &csa_stop;
    int rc = ef_gsusb_sim_run(&c, &m);
    if (rc != EF_OK)
        return cli_error(rc, "sim-adapter: %s", m.text);
    return EF_OK;
}

static const cli_cmd_t csa_kinds[] = {
    {"gsusb", csa_gsusb, "a gs_usb adapter (candleLight) on a USB gadget controller"},
    {NULL, NULL, NULL}};

/* Entry point of `evenfeed sim-adapter`. */
int cli_cmd_sim_adapter(int argc, char **argv)
{
    if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        fputs(usage, stdout);
        return EF_OK;
    }
    const cli_cmd_t *kind = argc >= 2 ? cli_cmd_find(csa_kinds, argv[1]) : NULL;
    if (!kind) {
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "sim-adapter: adapter '%s' is not supported (gsusb)",
                         argc >= 2 ? argv[1] : "");
    }
    return kind->fn(argc - 1, argv + 1);
}
