/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed demo: the built-in default job, runnable with no hardware and no input files:
 * smooth the shipped sample part programs (samples/bracket.ngc: lines, arcs, events;
 * samples/profile.ngc: CAM micro-segment curves and split edges; both embedded at build
 * time), print their summaries and write an SVG plot of each, then stream the profile to
 * a simulated Modbus drive over TCP on loopback (docs/modbus.md). */
#include <pthread.h>
#include <signal.h>
#include <string.h>
#include <unistd.h>
#include "cli.h"
#include "evenfeed/host/can/ef_canload.h"
#include "evenfeed/host/modbus/ef_mb.h"

/* Generated from samples/NAME.ngc by host/CMakeLists.txt. */
extern const char ef_sample_bracket[];
extern const unsigned long ef_sample_bracket_len;
extern const char ef_sample_profile[];
extern const unsigned long ef_sample_profile_len;

static const char usage[] =
    "usage: evenfeed demo [--svg PATH]   (default evenfeed-demo.svg; the second program's\n"
    "                                     plot goes next to it, PATH with -profile.svg)\n";

/* Smooth one embedded program and write its plot. */
static int cdemo_one(const char *text, unsigned long len, const char *name, const char *svg)
{
    static ef_gcode_t r; /* about 50 kB of parameters: not on the stack */
    printf("== samples/%s\n", name);
    fflush(stdout);
    int rc = ef_gcode_init(&r, text, (size_t)len, name);
    if (rc)
        return cli_error(rc, "demo: %s", ef_err_str(rc));
    cli_smooth_opts_t o;
    cli_smooth_opts_default(&o);
    o.svg = svg;
    char label[64];
    snprintf(label, sizeof label, "samples/%s", name);
    rc = cli_smooth_run(&r, label, &o);
    ef_gcode_free(&r);
    if (rc)
        return rc;
    printf("SVG plot written to %s\n\n", svg);
    fflush(stdout);
    return EF_OK;
}

static volatile sig_atomic_t cdemo_stop;

typedef struct {
    ef_mb_server_cfg_t c;
    ef_msg_t m;
    int rc;
} cdemo_srv_t;

/* The simulated drive's thread: serves until the demo sets cdemo_stop. */
static void *cdemo_serve(void *arg)
{
    cdemo_srv_t *S = arg;
    S->rc = ef_mb_serve(&S->c, &S->m);
    if (S->c.ready)
        fclose(S->c.ready); /* unblocks the reader if the server never got ready */
    return NULL;
}

/* Stream the profile to a simulated drive (in a thread of this process) over real Modbus
 * TCP on loopback, with the drive's clock at 4x so it takes a few seconds. */
static int cdemo_stream(void)
{
    static cdemo_srv_t S;
    int fds[2];
    if (pipe(fds) != 0)
        return cli_error(EF_ERR_IO, "demo: pipe");
    ef_mb_server_cfg_default(&S.c);
    S.c.mb.port = 0; /* any free port: the ready line says which */
    S.c.time_scale = 4.0;
    S.c.stop = &cdemo_stop;
    S.c.ready = fdopen(fds[1], "w");
    FILE *rd = fdopen(fds[0], "r");
    pthread_t th;
    if (!S.c.ready || !rd || pthread_create(&th, NULL, cdemo_serve, &S) != 0)
        return cli_error(EF_ERR_IO, "demo: cannot start the simulated drive");
    char line[256] = "";
    int port = 0;
    if (fgets(line, sizeof line, rd))
        sscanf(line, "ready tcp %*[^:]:%d", &port);
    fclose(rd);
    int rc = EF_OK;
    ef_msg_t m = {{0}};
    ef_mb_stream_result_t res;
    memset(&res, 0, sizeof res);
    if (port <= 0) {
        rc = EF_ERR_IO;
        ef_fail(&m, rc, "simulated drive did not start: %.400s", S.m.text);
    } else {
        printf("== samples/profile.ngc streamed to a simulated drive: Modbus TCP 127.0.0.1:%d, "
               "segment mode, drive clock 4x\n",
               port);
        fflush(stdout);
        static ef_gcode_t r;
        ef_mb_stream_cfg_t c;
        ef_mb_stream_cfg_default(&c, cli_default_table(EF_TABLE_G2_QUINTIC),
                                 cli_default_table(EF_TABLE_G1_CUBIC));
        c.mb.port = port;
        rc = ef_gcode_init(&r, ef_sample_profile, (size_t)ef_sample_profile_len, "profile.ngc");
        if (rc == EF_OK)
            rc = ef_mb_stream(&r, &c, &res, &m);
        ef_gcode_free(&r);
    }
    cdemo_stop = 1;
    pthread_join(th, NULL);
    if (rc != EF_OK)
        return cli_error(rc, "demo: stream: %s", m.text);
    printf("stream           %u segments, path time %.2f s, %llu Modbus transactions, "
           "%llu retries\n",
           res.moves, res.path_time, (unsigned long long)res.io.transactions,
           (unsigned long long)res.io.retries);
    printf("drive            executed %u segments, ended at rest at %.4f %.4f %.4f mm, "
           "following error max %.4f mm\n",
           res.last.done_count, (double)res.last.act[0], (double)res.last.act[1],
           (double)res.last.act[2], (double)res.last.ferr_max);
    return EF_OK;
}

/* The profile over CANopen to three drives on an in-process bus: segment mode and CSP, with
 * the bus load of each (the firmware master and drives; no CAN kernel needed). */
static int cdemo_can(void)
{
    printf(
        "\n== samples/profile.ngc over CANopen to three simulated CiA 402 drives (one per axis),\n"
        "   the firmware master and drives on an in-process bus at 1 Mbit/s (ctest -R hil_can\n"
        "   runs them over SocketCAN on a real vcan bus in User-Mode Linux)\n");
    fflush(stdout);
    static ef_gcode_t r;
    ef_msg_t m = {{0}};
    ef_pipe_cfg_t pc;
    ef_pipe_cfg_default(&pc);
    pc.g2 = cli_default_table(EF_TABLE_G2_QUINTIC);
    pc.g1 = cli_default_table(EF_TABLE_G1_CUBIC);
    pc.period_us = 1000; /* the CSP cycle */
    ef_canload_path_t path;
    int rc = ef_gcode_init(&r, ef_sample_profile, (size_t)ef_sample_profile_len, "profile.ngc");
    if (rc == EF_OK)
        rc = ef_canload_path(&r, &pc, &path, &m);
    ef_gcode_free(&r);
    if (rc != EF_OK)
        return cli_error(rc, "demo: can: %s", m.text);
    ef_canload_result_t res[2];
    static const int modes[2] = {EF_COM_MODE_SEGMENT, EF_COM_MODE_CSP};
    static const char *names[2] = {"segment mode", "CSP at 1 kHz"};
    for (int i = 0; i < 2 && rc == EF_OK; i++) {
        rc = ef_canload_run(&path, modes[i], 1000000u, &res[i], &m);
        if (rc != EF_OK)
            break;
        const ef_canload_result_t *q = &res[i];
        if (modes[i] == EF_COM_MODE_SEGMENT)
            printf("%-16s %zu segments; executed by each drive: %u %u %u\n", names[i], path.nmv,
                   q->executed[0], q->executed[1], q->executed[2]);
        else
            printf("%-16s %zu targets, one per drive per SYNC\n", names[i], path.nsp);
        printf("                 at rest %.4f mm from the end, following error max %.4f mm,"
               " bus %.1f kbit/s (%.1f %%), %.0f frames\n",
               q->end_err, q->ferr_max, q->bits / q->seconds * 1e-3, q->bits / q->seconds * 1e-4,
               q->frames);
    }
    ef_canload_path_free(&path);
    if (rc != EF_OK)
        return cli_error(rc, "demo: can: %s", m.text);
    printf("segment mode needs 1/%.1f of CSP's bus load (docs/benchmarks-can.md)\n",
           (res[1].bits / res[1].seconds) / (res[0].bits / res[0].seconds));
    return EF_OK;
}

enum { O_SVG = CLI_LONG };

int cli_cmd_demo(int argc, char **argv)
{
    static const struct option opts[] = {
        {"svg", required_argument, NULL, O_SVG}, CLI_OPT_HELP, CLI_OPT_END};
    const char *svg = "evenfeed-demo.svg";
    cli_getopt_t g;
    cli_getopt_init(&g, "demo", usage, argc, argv, "", opts);
    int c;
    while ((c = cli_getopt(&g)) > CLI_END) {
        if (c == CLI_HELP)
            return EF_OK;
        if (c != O_SVG) {
            fputs(usage, stderr);
            return cli_error(EF_ERR_ARG, "demo: unexpected argument '%s'", g.val);
        }
        svg = g.val;
    }
    if (c < 0)
        return c;
    if (!cli_default_table(EF_TABLE_G1_CUBIC) || !cli_default_table(EF_TABLE_G2_QUINTIC))
        return cli_error(EF_ERR_ARG, "demo: this build has no built-in tables");
    /* The second plot's name: PATH without a trailing .svg, plus -profile.svg. */
    char svg2[4096];
    size_t n = strlen(svg);
    if (n >= 4 && !strcmp(svg + n - 4, ".svg"))
        n -= 4;
    if (n + sizeof "-profile.svg" > sizeof svg2)
        return cli_error(EF_ERR_ARG, "demo: --svg path too long");
    memcpy(svg2, svg, n);
    memcpy(svg2 + n, "-profile.svg", sizeof "-profile.svg");
    printf("evenfeed demo: two sample part programs through the smoother, feed planner and\n"
           "interpolator (built-in G1/G2 tables, no hardware)\n\n");
    int rc = cdemo_one(ef_sample_bracket, ef_sample_bracket_len, "bracket.ngc", svg);
    if (rc)
        return rc;
    rc = cdemo_one(ef_sample_profile, ef_sample_profile_len, "profile.ngc", svg2);
    if (rc)
        return rc;
    rc = cdemo_stream();
    if (rc)
        return rc;
    return cdemo_can();
}
