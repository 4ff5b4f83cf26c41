/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed can: the USB-CAN adapters (gs_usb over libusb) present on this machine. */
#include <string.h>
#include "cli.h"
#include "evenfeed/host/can/ef_gsusb.h"

static const char usage[] =
    "usage: evenfeed can list [--json]\n"
    "\n"
    "List the USB-CAN adapters speaking gs_usb (candleLight, CANable; USB ids 1d50:606f,\n"
    "1209:2323, 1cd2:606f, 16d0:10b8), one line each: USB id, bus path, serial, product,\n"
    "firmware and hardware version, channels, CAN clock, features, and whether the kernel\n"
    "driver or another program has it. A free adapter is opened briefly to ask for its\n"
    "configuration; one the kernel drives is not touched. Use the serial or the bus path\n"
    "with `evenfeed stream --can gsusb:SERIAL` (docs/can.md).\n"
    "  --json   one JSON object: {\"adapters\": [...]}\n";

/* Who has the adapter, in words. */
static const char *ccan_owner(const ef_gsusb_info_t *e)
{
    if (e->driver_bound)
        return "kernel driver bound";
    if (e->claimed)
        return "claimed by another program";
    return e->queried ? "free" : "not opened";
}

static void ccan_line(const ef_gsusb_info_t *e)
{
    char fs[160];
    printf("%04x:%04x %s serial %s \"%s\"", (unsigned)e->vid, (unsigned)e->pid, e->path,
           e->serial[0] ? e->serial : "?", e->product);
    if (e->queried)
        printf(" fw %u hw %u, %u channel%s, %.3f MHz, features %s", (unsigned)e->sw_version,
               (unsigned)e->hw_version, (unsigned)e->channels, e->channels == 1 ? "" : "s",
               e->fclk / 1e6, ef_gsusb_feature_str(e->feature, fs, sizeof fs));
    printf("; %s", ccan_owner(e));
    if (e->note[0] && !e->queried && !e->driver_bound && !e->claimed)
        printf(" (%s)", e->note);
    putchar('\n');
}

static void ccan_json(const ef_gsusb_info_t *e, int first)
{
    char fs[160], id[16];
    snprintf(id, sizeof id, "%04x:%04x", (unsigned)e->vid, (unsigned)e->pid);
    printf("%s\n  {\"usb_id\": ", first ? "" : ",");
    cli_json_str(stdout, id);
    printf(", \"path\": ");
    cli_json_str(stdout, e->path);
    printf(", \"serial\": ");
    cli_json_str(stdout, e->serial);
    printf(", \"product\": ");
    cli_json_str(stdout, e->product);
    printf(", \"driver_bound\": %s, \"claimed\": %s, \"queried\": %s",
           e->driver_bound ? "true" : "false", e->claimed ? "true" : "false",
           e->queried ? "true" : "false");
    if (e->queried) {
        printf(", \"sw_version\": %u, \"hw_version\": %u, \"channels\": %u, \"fclk_hz\": %u, "
               "\"features\": ",
               (unsigned)e->sw_version, (unsigned)e->hw_version, (unsigned)e->channels,
               (unsigned)e->fclk);
        cli_json_str(stdout, ef_gsusb_feature_str(e->feature, fs, sizeof fs));
    }
    printf(", \"note\": ");
    cli_json_str(stdout, e->note);
    putchar('}');
}

enum { O_JSON = CLI_LONG };

int cli_cmd_can(int argc, char **argv)
{
    static const struct option opts[] = {
        {"json", no_argument, NULL, O_JSON}, CLI_OPT_HELP, CLI_OPT_END};
    if (argc < 2 || strcmp(argv[1], "list")) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            fputs(usage, stdout);
            return EF_OK;
        }
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "can: list is the one subcommand");
    }
    int json = 0, k;
    cli_getopt_t g;
    cli_getopt_init(&g, "can list", usage, argc - 1, argv + 1, "", opts);
    while ((k = cli_getopt(&g)) > CLI_END) {
        if (k == CLI_HELP)
            return EF_OK;
        if (k == O_JSON)
            json = 1;
        else if (k == CLI_ARG)
            return cli_error(EF_ERR_ARG, "can list: unexpected argument '%s'", g.val);
    }
    if (k < 0)
        return k;
    static ef_gsusb_info_t list[EF_GSUSB_LIST_MAX];
    int found = 0;
    ef_msg_t m = {{0}};
    int rc = ef_gsusb_list(list, EF_GSUSB_LIST_MAX, &found, &m);
    if (rc != EF_OK)
        return cli_error(rc, "can list: %s", m.text);
    int n = found < EF_GSUSB_LIST_MAX ? found : EF_GSUSB_LIST_MAX;
    if (json) {
        printf("{\"adapters\": [");
        for (int i = 0; i < n; i++)
            ccan_json(&list[i], i == 0);
        printf("%s]}\n", n ? "\n" : "");
    } else if (n == 0) {
        printf("no gs_usb adapter found\n");
    } else {
        for (int i = 0; i < n; i++)
            ccan_line(&list[i]);
        if (found > n)
            printf("(%d more not listed)\n", found - n);
    }
    fflush(stdout);
    return EF_OK;
}
