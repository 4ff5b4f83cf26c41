/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed io: the machine file's GPIO lines (docs/io.md): status, reset of the e-stop
 * latch; and the machine I/O the streamers share (cli_mio_open()). */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include "cli.h"
#include "evenfeed/host/io/ef_mio.h"

static const char usage[] =
    "usage: evenfeed io status --machine FILE\n"
    "       evenfeed io reset --machine FILE\n"
    "\n"
    "The machine I/O of a machine file (docs/io.md) on its GPIO lines.\n"
    "  status  request every line, print its function, line and logical value, and\n"
    "          whether the e-stop latch is set; release them again\n"
    "  reset   leave e-stop: remove the latch a trip wrote, only while the e-stop input\n"
    "          reads released\n";

/* Safe outputs, then the default action: a signal must not leave a drive enabled. */
static void cio_on_signal(int sig)
{
    ef_gpio_safe_all();
    signal(sig, SIG_DFL);
    raise(sig);
}

/* Exit paths of a process that drives outputs: signals and exit() drive them safe. */
static void cio_guard(void)
{
    static int done;
    if (done)
        return;
    done = 1;
    atexit(ef_gpio_safe_all);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = cio_on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    sigaction(SIGQUIT, &sa, NULL);
    sigaction(SIGABRT, &sa, NULL);
    sigaction(SIGSEGV, &sa, NULL);
    sigaction(SIGBUS, &sa, NULL);
    sigaction(SIGFPE, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

int cli_mio_open(ef_mio_t *io, const char *path)
{
    static ef_mio_cfg_t c; /* several kB: not on the stack */
    ef_msg_t m = {{0}};
    int rc = ef_mio_cfg_load(&c, path, &m);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    cio_guard();
    rc = ef_mio_open(io, &c, &m);
    if (rc != EF_OK)
        return cli_error(rc, "machine %s: %s", path, m.text);
    return EF_OK;
}

enum { O_MACHINE = CLI_LONG };

int cli_cmd_io(int argc, char **argv)
{
    static const struct option opts[] = {
        {"machine", required_argument, NULL, O_MACHINE}, CLI_OPT_HELP, CLI_OPT_END};
    if (argc < 2 || (strcmp(argv[1], "status") && strcmp(argv[1], "reset"))) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            fputs(usage, stdout);
            return EF_OK;
        }
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "io: status or reset");
    }
    const char *sub = argv[1], *path = NULL;
    cli_getopt_t g;
    cli_getopt_init(&g, sub[0] == 's' ? "io status" : "io reset", usage, argc - 1, argv + 1, "",
                    opts);
    int k;
    while ((k = cli_getopt(&g)) > CLI_END) {
        if (k == CLI_HELP)
            return EF_OK;
        if (k == O_MACHINE)
            path = g.val;
        else if (k == CLI_ARG)
            return cli_error(EF_ERR_ARG, "io %s: unexpected argument '%s'", sub, g.val);
    }
    if (k < 0)
        return k;
    if (!path)
        return cli_error(EF_ERR_ARG, "io %s: --machine FILE is required", sub);
    static ef_mio_cfg_t c;
    ef_msg_t m = {{0}};
    int rc = ef_mio_cfg_load(&c, path, &m);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    if (!strcmp(sub, "reset")) {
        int had = access(c.latch, F_OK) == 0;
        rc = ef_mio_reset(&c, &m);
        if (rc != EF_OK)
            return cli_error(rc, "%s", m.text);
        printf("io reset: %s\n", had ? "e-stop latch removed" : "no e-stop latch was set");
        return EF_OK;
    }
    static ef_mio_t io;
    if ((rc = cli_mio_open(&io, path)) != EF_OK)
        return rc;
    /* Status reads, never arms; the inputs' levels are the I/O thread's, after a few of
     * its rounds (the debounce). */
    struct timespec ts = {0, 20000000L};
    nanosleep(&ts, NULL);
    for (unsigned i = 0; i < io.cfg.n; i++) {
        const ef_gpio_t *set = io.cfg.lines[i].dir == EF_GPIO_OUT ? &io.out : &io.in;
        char nm[160];
        uint8_t v = 0;
        pthread_mutex_lock(&io.mu);
        (void)ef_gpio_get(set, (unsigned)io.set_of[i], &v);
        ef_gpio_name(set, (unsigned)io.set_of[i], nm, sizeof nm);
        pthread_mutex_unlock(&io.mu);
        printf("%-12s %-5s %s = %s\n", io.cfg.lines[i].what,
               io.cfg.lines[i].dir == EF_GPIO_OUT ? "out" : "in", nm, v ? "active" : "inactive");
    }
    if (io.cfg.pump >= 0)
        printf("%-12s %-5s %s:%s, %u Hz while armed\n", "charge_pump", "out", io.cfg.pump_line.chip,
               io.cfg.pump_line.line, (unsigned)io.cfg.pump_hz);
    if (io.cfg.estop >= 0)
        printf("e-stop latch %s: %s\n", io.cfg.latch,
               access(io.cfg.latch, F_OK) == 0 ? "SET (evenfeed io reset)" : "clear");
    ef_mio_close(&io);
    return EF_OK;
}
