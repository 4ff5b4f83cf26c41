/* SPDX-License-Identifier: Apache-2.0 */
/* The machine file (host/lib/io/ef_mio.c, docs/io.md): what it wires, its defaults, and each
 * kind of bad line refused with file:line and nothing applied. No GPIO needed (the parse
 * opens no line); the machine I/O itself runs in the hil_io_* tests.
 *
 *   test_mio DIR cfg    DIR: where the test writes its machine files */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ef_test.h"
#include "evenfeed/host/io/ef_mio.h"

static const char *g_dir = ".";

/* Write text to DIR/name; its path. */
static const char *tm_file(const char *name, const char *text)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", g_dir, name);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
    return path;
}

static ef_mio_cfg_t g_c;

/* A whole machine file: every function wired, defaults and explicit values. */
static void t_cfg_good(void)
{
    const char *p = tm_file("good.ini", "# a machine\n"
                                        "[gpio]\nchip = gpiochip3 ; default chip\n"
                                        "debounce_ms = 4\n"
                                        "[estop]\nline = ESTOP\nlatch = /tmp/x.latch\n"
                                        "[enable]\nlines = EN_X EN_Y gpiochip1:7\n"
                                        "[alarm]\nlines = 5, 6\ncontact = nc\nbias = pull-up\n"
                                        "[feed_hold]\nline = HOLD\ndebounce_ms = 10\n"
                                        "[cycle_start]\nline = START\n"
                                        "[charge_pump]\nline = PUMP\nhz = 1000\n"
                                        "[outputs]\np0 = OUT0\np7 = gpiochip2:3\nactive = low\n");
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_mio_cfg_load(&g_c, p, &m), EF_OK);
    if (m.text[0])
        printf("%s\n", m.text);
    EF_CHECK(g_c.estop >= 0 && g_c.hold >= 0 && g_c.start >= 0 && g_c.pump >= 0);
    EF_CHECK_EQ(g_c.n_enable, 3u);
    EF_CHECK_EQ(g_c.n_alarm, 2u);
    /* e-stop: NC by default (active low), the [gpio] chip and debounce */
    const ef_gpio_line_cfg_t *e = &g_c.lines[g_c.estop];
    EF_CHECK(!strcmp(e->chip, "gpiochip3") && !strcmp(e->line, "ESTOP"));
    EF_CHECK_EQ(e->active_low, 1);
    EF_CHECK_EQ(e->debounce_us, 4000u);
    EF_CHECK_EQ(e->dir, EF_GPIO_IN);
    /* enable: outputs, chip per line, safe = inactive */
    const ef_gpio_line_cfg_t *en = &g_c.lines[g_c.enable[2]];
    EF_CHECK(!strcmp(en->chip, "gpiochip1") && !strcmp(en->line, "7"));
    EF_CHECK_EQ(en->dir, EF_GPIO_OUT);
    EF_CHECK_EQ(en->safe, 0);
    /* alarms: contact nc, bias, offsets */
    const ef_gpio_line_cfg_t *al = &g_c.lines[g_c.alarm[1]];
    EF_CHECK(!strcmp(al->line, "6") && al->active_low == 1 && al->bias == EF_GPIO_BIAS_PULL_UP);
    /* feed hold: NO by default, its own debounce */
    EF_CHECK_EQ(g_c.lines[g_c.hold].active_low, 0);
    EF_CHECK_EQ(g_c.lines[g_c.hold].debounce_us, 10000u);
    EF_CHECK_EQ(g_c.pump_hz, 1000u);
    EF_CHECK(!strcmp(g_c.pump_line.line, "PUMP"));
    EF_CHECK(g_c.out[0] >= 0 && g_c.out[7] >= 0 && g_c.out[3] < 0);
    EF_CHECK_EQ(g_c.lines[g_c.out[7]].active_low, 1);
    EF_CHECK(!strcmp(g_c.latch, "/tmp/x.latch"));
    EF_CHECK_EQ(g_c.stop_ms, 2000u);
    EF_CHECK_EQ(g_c.pump_watchdog_ms, 250u);
}

/* Defaults: the latch beside the runtime directory, named after the file. */
static void t_cfg_defaults(void)
{
    const char *p = tm_file("mill.ini", "[estop]\nline = gpiochip0:2\n");
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_mio_cfg_load(&g_c, p, &m), EF_OK);
    EF_CHECK(strstr(g_c.latch, "evenfeed-mill.ini.estop") != NULL);
    EF_CHECK_EQ(g_c.lines[g_c.estop].debounce_us, 2000u);
    EF_CHECK_EQ(g_c.lines[g_c.estop].bias, EF_GPIO_BIAS_AS_IS);
    EF_CHECK(g_c.pump < 0 && g_c.hold < 0 && g_c.n_enable == 0);
}

/* Each bad file: refused with its line number and a word of the cause; nothing kept. */
static void t_cfg_bad(void)
{
    static const struct {
        const char *text, *where, *why;
    } bad[] = {
        {"[estop]\nline = A\n[bogus]\n", ":3:", "unknown section"},
        {"[estop]\nline = A\nwire = 3\n", ":3:", "unknown key 'wire'"},
        {"[gpio]\nchip = c\n[estop]\nline = A\n[enable]\nline = A\n", ":5:", "already wired"},
        {"[gpio]\nchip = c\n[estop]\nline = A\n[alarm]\nline = c:A\n", ":5:", "already wired"},
        {"[estop]\nline = A\n", ":1:", "names no chip"},
        {"[gpio]\nchip = c\n[enable]\nline = EN\n", "", "without [estop]"},
        {"[gpio]\nchip = c\n[estop]\nline = A\ncontact = maybe\n", ":5:", "contact 'maybe'"},
        {"[gpio]\ndebounce_ms = -1\n", ":2:", "debounce_ms"},
        {"[gpio]\nchip = c\n[estop]\nline = A B\n", ":4:", "at most 1"},
        {"[gpio]\nchip = c\n[estop]\nline = A\n[estop]\nline = B\n", ":5:", "given twice"},
        {"line = A\n", ":1:", "before any [section]"},
        {"[gpio]\nchip = c\n[estop]\nline A\n", ":4:", "key = value"},
        {"[gpio]\nchip = c\n[charge_pump]\nline = P\nhz = 0\n", ":5:", "hz '0'"},
        {"[gpio]\nchip = c\n[outputs]\np8 = X\n", ":4:", "unknown key 'p8'"},
        {"[gpio]\nchip = c\n[estop]\n", ":3:", "wires no line"},
        {"[gpio]\nchip = c\n[estop]\nline = A\nbias = sideways\n", ":5:", "bias 'sideways'"},
        {"[gpio]\nchip = c\n[enable]\nlines = A B C D\n", ":4:", "at most 3"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char name[32];
        snprintf(name, sizeof name, "bad%zu.ini", i);
        const char *p = tm_file(name, bad[i].text);
        ef_msg_t m = {{0}};
        int rc = ef_mio_cfg_load(&g_c, p, &m);
        int ok = rc == EF_ERR_ARG && strstr(m.text, name) && strstr(m.text, bad[i].where) &&
                 strstr(m.text, bad[i].why) && g_c.n == 0;
        if (!ok)
            fprintf(stderr, "bad file %zu: rc %d, message '%s' (wanted '%s' and '%s')\n", i, rc,
                    m.text, bad[i].where, bad[i].why);
        EF_CHECK(ok);
    }
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_mio_cfg_load(&g_c, "/nonexistent/machine.ini", &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "/nonexistent/machine.ini") != NULL);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"cfg", t_cfg_good},
        {"cfg", t_cfg_defaults},
        {"cfg", t_cfg_bad},
    };
    if (argc < 2) {
        fprintf(stderr, "usage: test_mio DIR [cfg]\n");
        return 2;
    }
    g_dir = argv[1];
    return EF_TEST_RUN(argc, argv, 2, parts);
}
