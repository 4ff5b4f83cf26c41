/* SPDX-License-Identifier: Apache-2.0 */
/* GPIO lines (host/lib/io/ef_gpio.c, libgpiod 1.6) tests.
 *
 *   test_gpio offline               on any host (no /dev/gpiochip* needed): argument checks,
 *                                   an unknown chip, nothing left open after a failure, calls
 *                                   on a set that is not open
 *   test_gpio sim_open CHIP SYSDIR  inside User-Mode Linux with a gpio-sim chip made by
 *   test_gpio sim_errors ...        tests/hil/gpio.sh (CHIP: its /dev/gpiochipX, SYSDIR:
 *   test_gpio sim_debounce ...      /sys/devices/platform/gpio-sim.N/gpiochipX): the lines
 *   test_gpio sim_safe ...          are driven through gpio-sim's sysfs "pull" files and read
 *                                   back through its "value" files (what gpio_lib.sh's
 *                                   gsim_pull / gsim_value do), the consumer through gpioinfo
 *
 * A sim part run without CHIP and SYSDIR (e.g. in a run of all parts) is skipped. */
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <gpiod.h>

#include "ef_test.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/host/io/ef_gpio.h"

/* The simulated chip's layout, made by tests/hil/gpio.sh (keep in step). */
#define SIM_LABEL  "efsim"
#define SIM_LINES  8
#define SIM_ESTOP  0 /* "ESTOP" */
#define SIM_LIMIT  1 /* "LIMIT" */
#define SIM_ENABLE 2 /* "ENABLE" */
#define SIM_BRAKE  3 /* "BRAKE" */
#define SIM_PROBE  4 /* "PROBE" */
#define SIM_AUX    6 /* no name */
#define SIM_HOG    7 /* "HOGGED", held by the kernel hog "ef-hog" (output-high) */
#define SIM_HOG_BY "ef-hog"

/* How long after the pull is written the kernel may timestamp the edge. gpio-sim raises its
 * interrupts through irq_sim's irq_work, which UML (no irq_work interrupt) runs from its
 * 100 Hz tick: the edges' timestamps are those of the next tick, up to 10 ms late. */
#define TG_EDGE_DELAY_NS 12000000u
/* How late after its debounce interval a change may be taken (a loaded 2-core host). */
#define TG_SLACK_NS 50000000u

static const char *sim_chip; /* /dev/gpiochipX */
static const char *sim_sys;  /* /sys/devices/platform/gpio-sim.N/gpiochipX */
static char sim_name[64];    /* gpiochipX */
static char sim_num[16];     /* X */

static uint64_t tg_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* Sleep until the monotonic time t_ns. */
static void tg_sleep_until(uint64_t t_ns)
{
    struct timespec ts = {(time_t)(t_ns / 1000000000u), (long)(t_ns % 1000000000u)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
        ;
}

/* Open descriptors of this process. */
static int tg_fd_count(void)
{
    DIR *d = opendir("/proc/self/fd");
    int n = 0;
    if (!d)
        return -1;
    while (readdir(d))
        n++;
    closedir(d);
    return n;
}

/* A line configuration. */
static ef_gpio_line_cfg_t tg_cfg(const char *what, const char *chip, const char *line, int dir)
{
    ef_gpio_line_cfg_t c;
    memset(&c, 0, sizeof c);
    c.what = what;
    snprintf(c.chip, sizeof c.chip, "%s", chip);
    snprintf(c.line, sizeof c.line, "%s", line);
    c.dir = (uint8_t)dir;
    return c;
}

/* Whether the message contains s (reporting it when not). */
static int tg_has(const ef_msg_t *m, const char *s)
{
    if (strstr(m->text, s))
        return 1;
    fprintf(stderr, "message '%s' lacks '%s'\n", m->text, s);
    return 0;
}

/* ---------------------------------------------------------------------------------------
 * offline
 * ------------------------------------------------------------------------------------- */

static void t_offline_args(void)
{
    ef_gpio_t g;
    ef_msg_t m;
    ef_gpio_line_cfg_t c[EF_GPIO_MAX_LINES + 1];
    for (unsigned k = 0; k <= EF_GPIO_MAX_LINES; k++)
        c[k] = tg_cfg(NULL, "gpiochip999", "0", EF_GPIO_IN);
    c[0].what = "estop";

    m.text[0] = 0;
    EF_CHECK_EQ(ef_gpio_open(&g, c, 0, &m), EF_ERR_ARG);
    EF_CHECK(m.text[0] != 0);
    EF_CHECK_EQ(g.open, 0);
    EF_CHECK_EQ(ef_gpio_open(&g, c, EF_GPIO_MAX_LINES + 1, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "lines"));
    EF_CHECK_EQ(ef_gpio_open(&g, NULL, 1, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_open(NULL, c, 1, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_open(&g, c, 1, NULL), EF_ERR_IO); /* no message buffer: code only */

    ef_gpio_line_cfg_t b[2] = {c[0], tg_cfg(NULL, "gpiochip0", "1", EF_GPIO_OUT)};
    b[0].chip[0] = 0;
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "estop") && tg_has(&m, "chip"));
    b[0] = c[0];
    b[1].line[0] = 0;
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "line 1") && tg_has(&m, "no line"));
    b[1] = tg_cfg("enable", "gpiochip0", "1", 2);
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "enable") && tg_has(&m, "direction"));
    b[1] = tg_cfg("enable", "gpiochip0", "1", EF_GPIO_OUT);
    b[1].bias = EF_GPIO_BIAS_PULL_DOWN + 1;
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "enable") && tg_has(&m, "bias"));
    /* A field without its terminating NUL. */
    b[1] = tg_cfg("enable", "gpiochip0", "1", EF_GPIO_OUT);
    memset(b[1].line, '1', sizeof b[1].line);
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    /* Argument errors come before any chip is opened: the bad entry is the second. */
    b[0] = tg_cfg("estop", "gpiochip999", "0", EF_GPIO_IN);
    b[1] = tg_cfg("enable", "gpiochip0", "", EF_GPIO_OUT);
    EF_CHECK_EQ(ef_gpio_open(&g, b, 2, &m), EF_ERR_ARG);
    EF_CHECK_EQ(g.open, 0);
}

static void t_offline_nochip(void)
{
    static const char *const chips[] = {"gpiochip999", "/dev/gpiochip999", "999", "no-such-label"};
    ef_gpio_t g;
    ef_msg_t m;
    int fds = tg_fd_count();
    for (unsigned i = 0; i < sizeof chips / sizeof chips[0]; i++) {
        ef_gpio_line_cfg_t c[2] = {tg_cfg("estop", chips[i], "ESTOP", EF_GPIO_IN),
                                   tg_cfg("enable", chips[i], "3", EF_GPIO_OUT)};
        m.text[0] = 0;
        EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
        char want[128];
        snprintf(want, sizeof want, "gpio: estop: chip '%s': no such chip", chips[i]);
        EF_CHECK(tg_has(&m, want));
        EF_CHECK(tg_has(&m, "gpiod_chip_open_lookup"));
        EF_CHECK_EQ(g.open, 0);
        EF_CHECK_EQ(g.n, 0);
        EF_CHECK(g.l[0].chip == NULL && g.l[0].line == NULL);
        ef_gpio_close(&g); /* after a failed open: nothing to do */
    }
    printf("offline: %s\n", m.text);
    EF_CHECK_EQ(tg_fd_count(), fds);
}

static void t_offline_closed(void)
{
    ef_gpio_t g;
    ef_msg_t m;
    uint8_t v = 7;
    uint32_t next = 0;
    char buf[64];
    memset(&g, 0, sizeof g);
    ef_gpio_close(&g); /* never opened */
    ef_gpio_close(&g);
    ef_gpio_close(NULL);
    EF_CHECK_EQ(ef_gpio_get(&g, 0, &v), EF_ERR_ARG);
    EF_CHECK_EQ(v, 7);
    EF_CHECK_EQ(ef_gpio_get(NULL, 0, &v), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_set(&g, 0, 1, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_set(&g, EF_GPIO_MAX_LINES, 1, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_process(&g, tg_now_ns(), &next, &m), EF_ERR_STATE);
    EF_CHECK_EQ(next, UINT32_MAX);
    EF_CHECK_EQ(ef_gpio_process(NULL, 0, NULL, NULL), EF_ERR_STATE);
    EF_CHECK_EQ(ef_gpio_wait(&g, 0), EF_ERR_STATE);
    EF_CHECK_EQ(ef_gpio_safe(&g, &m), EF_OK);
    ef_gpio_event_t ev;
    EF_CHECK_EQ(ef_gpio_next_event(&g, &ev), 0);
    EF_CHECK_EQ(ef_gpio_find(&g, "estop"), -1);
    EF_CHECK_EQ(ef_gpio_find(NULL, "estop"), -1);
    EF_CHECK(strcmp(ef_gpio_name(&g, 3, buf, sizeof buf), "line 3") == 0);
    EF_CHECK(strcmp(ef_gpio_name(&g, 3, buf, 0), "") == 0);
    ef_gpio_safe_all(); /* nothing open: nothing to do */

    /* A set whose open failed is closed: same answers. */
    ef_gpio_line_cfg_t c = tg_cfg("estop", "gpiochip999", "0", EF_GPIO_IN);
    EF_CHECK_EQ(ef_gpio_open(&g, &c, 1, &m), EF_ERR_IO);
    EF_CHECK_EQ(ef_gpio_get(&g, 0, &v), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gpio_set(&g, 0, 0, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "not open"));
    EF_CHECK_EQ(ef_gpio_process(&g, tg_now_ns(), NULL, &m), EF_ERR_STATE);
    ef_gpio_close(&g);
}

/* ---------------------------------------------------------------------------------------
 * gpio-sim (inside User-Mode Linux)
 * ------------------------------------------------------------------------------------- */

/* The part's CHIP and SYSDIR arguments; 0 (part skipped) without them. */
static int tg_sim_args(void)
{
    if (ef_t_argc != 2) {
        ef_test_skip("needs a gpio-sim chip: CHIP SYSDIR (run by tests/hil/gpio.sh in UML)");
        return 0;
    }
    sim_chip = ef_t_argv[0];
    sim_sys = ef_t_argv[1];
    const char *b = strrchr(sim_chip, '/');
    snprintf(sim_name, sizeof sim_name, "%s", b ? b + 1 : sim_chip);
    snprintf(sim_num, sizeof sim_num, "%s", sim_name + strcspn(sim_name, "0123456789"));
    return 1;
}

/* Path of a line's gpio-sim attribute ("pull" or "value"). */
static const char *tg_sim_path(char *buf, size_t n, unsigned off, const char *attr)
{
    snprintf(buf, n, "%s/sim_gpio%u/%s", sim_sys, off, attr);
    return buf;
}

/* The line's level as gpio-sim has it (gsim_value); -1 on error. */
static int tg_sim_value(unsigned off)
{
    char p[300], b[8] = {0};
    int fd = open(tg_sim_path(p, sizeof p, off, "value"), O_RDONLY);
    if (fd < 0)
        return -1;
    ssize_t r = read(fd, b, sizeof b - 1);
    close(fd);
    return r > 0 && (b[0] == '0' || b[0] == '1') ? b[0] - '0' : -1;
}

/* Pull a line up or down from the simulated outside (gsim_pull); 0 on success. */
static int tg_sim_pull(unsigned off, int up)
{
    char p[300];
    const char *s = up ? "pull-up" : "pull-down";
    int fd = open(tg_sim_path(p, sizeof p, off, "pull"), O_WRONLY);
    if (fd < 0)
        return -1;
    ssize_t r = write(fd, s, strlen(s));
    close(fd);
    return r == (ssize_t)strlen(s) ? 0 : -1;
}

/* Lines of the sim chip held by "evenfeed", as gpioinfo shows them; -1 on error. */
static int tg_gpioinfo_ours(void)
{
    char cmd[128], line[256];
    snprintf(cmd, sizeof cmd, "gpioinfo %s 2>&1", sim_name);
    FILE *p = popen(cmd, "r");
    int n = 0;
    if (!p)
        return -1;
    while (fgets(line, sizeof line, p))
        if (strstr(line, "\"" EF_GPIO_CONSUMER "\""))
            n++;
    return pclose(p) == 0 ? n : -1;
}

/* A debounced change with the time it was taken from the ring. */
typedef struct {
    ef_gpio_event_t ev;
    uint64_t seen_ns;
} tg_seen_t;

typedef struct {
    tg_seen_t s[256];
    int n;
    uint32_t next_min, next_max; /* next_us values other than UINT32_MAX */
    int next_seen;
    int rc; /* first error of ef_gpio_process / ef_gpio_wait, or EF_OK */
} tg_log_t;

/* Process and collect debounced changes until the monotonic time until_ns. */
static void tg_collect(ef_gpio_t *g, uint64_t until_ns, tg_log_t *log)
{
    ef_msg_t m;
    for (;;) {
        uint64_t now = tg_now_ns();
        uint32_t next;
        int r = ef_gpio_process(g, now, &next, &m);
        if (r < 0) {
            fprintf(stderr, "ef_gpio_process: %s\n", m.text);
            if (log->rc == EF_OK)
                log->rc = r;
            return;
        }
        if (next != UINT32_MAX) {
            if (!log->next_seen || next < log->next_min)
                log->next_min = next;
            if (!log->next_seen || next > log->next_max)
                log->next_max = next;
            log->next_seen = 1;
        }
        ef_gpio_event_t ev;
        while (ef_gpio_next_event(g, &ev)) {
            if (log->n < (int)(sizeof log->s / sizeof log->s[0])) {
                log->s[log->n].ev = ev;
                log->s[log->n].seen_ns = now;
                log->n++;
            }
        }
        if (now >= until_ns)
            return;
        uint64_t left_us = (until_ns - now) / 1000u + 1;
        uint32_t to = left_us < next ? (uint32_t)left_us : next;
        r = ef_gpio_wait(g, to);
        if (r < 0 && log->rc == EF_OK)
            log->rc = r;
    }
}

/* Changes of line k in the log. */
static int tg_count(const tg_log_t *log, unsigned k)
{
    int n = 0;
    for (int i = 0; i < log->n; i++)
        n += log->s[i].ev.line == k;
    return n;
}

static void tg_print(const char *what, const tg_log_t *log, uint64_t t0)
{
    printf("%s: %d change(s)\n", what, log->n);
    for (int i = 0; i < log->n; i++)
        printf("  line %u -> %u at %+.3f ms (taken at %+.3f ms)\n", log->s[i].ev.line,
               log->s[i].ev.value, ((double)log->s[i].ev.t_ns - (double)t0) / 1e6,
               ((double)log->s[i].seen_ns - (double)t0) / 1e6);
}

static void t_sim_open(void)
{
    if (!tg_sim_args())
        return;
    ef_gpio_t g;
    ef_msg_t m;
    char buf[96], want[96];
    uint8_t v;
    int fds = tg_fd_count();

    /* The chip by path, name, label and number; lines by name and by offset. */
    ef_gpio_line_cfg_t c[6] = {tg_cfg("estop", sim_chip, "ESTOP", EF_GPIO_IN),
                               tg_cfg("limit", sim_name, "1", EF_GPIO_IN),
                               tg_cfg("enable", sim_chip, "ENABLE", EF_GPIO_OUT),
                               tg_cfg("brake", sim_chip, "3", EF_GPIO_OUT),
                               tg_cfg("probe", SIM_LABEL, "PROBE", EF_GPIO_IN),
                               tg_cfg(NULL, sim_num, "6", EF_GPIO_OUT)};
    c[1].active_low = 1;
    c[3].active_low = 1; /* safe 0 (released) is the high level */
    c[4].bias = EF_GPIO_BIAS_PULL_UP;
    c[5].safe = 1;
    for (unsigned k = 0; k < SIM_LINES; k++)
        if (k != SIM_HOG)
            EF_CHECK_EQ(tg_sim_pull(k, 0), 0);

    int rc = ef_gpio_open(&g, c, 6, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "ef_gpio_open: %s\n", m.text);
        return;
    }
    EF_CHECK_EQ(g.open, 1);
    EF_CHECK_EQ(g.n, 6);
    for (unsigned k = 1; k < 6; k++)
        EF_CHECK(g.l[k].chip == g.l[0].chip); /* one gpiod_chip for the four spellings */
    EF_CHECK_EQ(g.l[0].offset, SIM_ESTOP);
    EF_CHECK_EQ(g.l[1].offset, SIM_LIMIT);
    EF_CHECK_EQ(g.l[2].offset, SIM_ENABLE);
    EF_CHECK_EQ(g.l[3].offset, SIM_BRAKE);
    EF_CHECK_EQ(g.l[4].offset, SIM_PROBE);
    EF_CHECK_EQ(g.l[5].offset, SIM_AUX);
    EF_CHECK(g.l[0].fd >= 0 && g.l[1].fd >= 0 && g.l[4].fd >= 0);
    EF_CHECK(g.l[2].fd == -1 && g.l[3].fd == -1 && g.l[5].fd == -1);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 6);
    char cmd[96];
    snprintf(cmd, sizeof cmd, "gpioinfo %s", sim_name);
    fflush(stdout);
    EF_CHECK_EQ(system(cmd), 0); /* for the log: the lines as the kernel shows them */

    /* Outputs at their safe values from the request on (active-low inverts). */
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 0);
    EF_CHECK_EQ(tg_sim_value(SIM_BRAKE), 1);
    EF_CHECK_EQ(tg_sim_value(SIM_AUX), 1);
    EF_CHECK(ef_gpio_get(&g, 3, &v) == EF_OK && v == 0);
    EF_CHECK(ef_gpio_get(&g, 5, &v) == EF_OK && v == 1);
    /* Inputs: the levels at open; active-low inverts; the pull-up bias reached the chip. */
    EF_CHECK(ef_gpio_get(&g, 0, &v) == EF_OK && v == 0);
    EF_CHECK(ef_gpio_get(&g, 1, &v) == EF_OK && v == 1);
    EF_CHECK(ef_gpio_get(&g, 4, &v) == EF_OK && v == 1);
    EF_CHECK_EQ(tg_sim_value(SIM_PROBE), 1);
    EF_CHECK_EQ(ef_gpio_get(&g, 6, &v), EF_ERR_ARG);

    EF_CHECK_EQ(ef_gpio_find(&g, "brake"), 3);
    EF_CHECK_EQ(ef_gpio_find(&g, "nope"), -1);
    snprintf(want, sizeof want, "brake (%s:3)", sim_name);
    EF_CHECK(strcmp(ef_gpio_name(&g, 3, buf, sizeof buf), want) == 0);
    snprintf(want, sizeof want, "line 5 (%s:6)", sim_name);
    EF_CHECK(strcmp(ef_gpio_name(&g, 5, buf, sizeof buf), want) == 0);

    /* Driving outputs. */
    EF_CHECK_EQ(ef_gpio_set(&g, 2, 1, &m), EF_OK);
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 1);
    EF_CHECK_EQ(ef_gpio_set(&g, 3, 1, &m), EF_OK);
    EF_CHECK_EQ(tg_sim_value(SIM_BRAKE), 0);
    EF_CHECK(ef_gpio_get(&g, 3, &v) == EF_OK && v == 1);
    EF_CHECK_EQ(ef_gpio_set(&g, 0, 1, &m), EF_ERR_ARG); /* an input */
    EF_CHECK(tg_has(&m, "estop") && tg_has(&m, "input"));
    EF_CHECK_EQ(ef_gpio_set(&g, 6, 1, &m), EF_ERR_ARG);

    /* Edges, no debounce: an input pulled up is reported at once, with the edge's time;
     * the active-low one pulled up goes to 0. */
    tg_log_t *log = calloc(1, sizeof *log);
    uint32_t next = 0;
    EF_CHECK_EQ(ef_gpio_process(&g, tg_now_ns(), &next, &m), 0);
    EF_CHECK_EQ(next, UINT32_MAX);
    EF_CHECK_EQ(ef_gpio_wait(&g, 0), 0);
    uint64_t t0 = tg_now_ns();
    EF_CHECK_EQ(tg_sim_pull(SIM_ESTOP, 1), 0);
    EF_CHECK_EQ(ef_gpio_wait(&g, 2000000), 1);
    EF_CHECK_EQ(tg_sim_pull(SIM_LIMIT, 1), 0);
    tg_collect(&g, tg_now_ns() + 50000000u, log);
    tg_print("sim_open edges", log, t0);
    EF_CHECK_EQ(log->rc, EF_OK);
    EF_CHECK_EQ(log->n, 2);
    if (log->n == 2) {
        EF_CHECK(log->s[0].ev.line == 0 && log->s[0].ev.value == 1);
        EF_CHECK(log->s[1].ev.line == 1 && log->s[1].ev.value == 0);
        EF_CHECK(log->s[0].ev.t_ns >= t0 && log->s[0].ev.t_ns <= log->s[1].ev.t_ns);
        EF_CHECK(log->s[1].ev.t_ns <= log->s[1].seen_ns);
    }
    EF_CHECK(ef_gpio_get(&g, 0, &v) == EF_OK && v == 1);
    EF_CHECK(ef_gpio_get(&g, 1, &v) == EF_OK && v == 0);
    EF_CHECK_EQ(g.l[0].edges, 1);
    EF_CHECK_EQ(g.l[1].edges, 1);
    EF_CHECK_EQ(g.l[0].rejected, 0);
    free(log);

    ef_gpio_close(&g);
    EF_CHECK_EQ(g.open, 0);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 0);
    EF_CHECK_EQ(tg_fd_count(), fds);
    ef_gpio_close(&g); /* twice: nothing */
    EF_CHECK_EQ(ef_gpio_get(&g, 0, &v), EF_ERR_ARG);

    /* Everything was released: the same set opens again. */
    EF_CHECK_EQ(ef_gpio_open(&g, c, 6, &m), EF_OK);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 6);
    ef_gpio_close(&g);
    EF_CHECK_EQ(tg_fd_count(), fds);
    for (unsigned k = 0; k < SIM_LINES; k++)
        if (k != SIM_HOG)
            tg_sim_pull(k, 0);
}

static void t_sim_errors(void)
{
    if (!tg_sim_args())
        return;
    ef_gpio_t g, h;
    ef_msg_t m;
    char want[128];
    int fds = tg_fd_count();
    memset(&h, 0, sizeof h);

    /* No such line: by name, by offset. */
    ef_gpio_line_cfg_t c[2] = {tg_cfg("estop", sim_chip, "ESTOP", EF_GPIO_IN),
                               tg_cfg("limit", sim_chip, "NOPE", EF_GPIO_IN)};
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
    snprintf(want, sizeof want, "gpio: limit: line 'NOPE' not found on %s", sim_name);
    EF_CHECK(tg_has(&m, want));
    printf("sim_errors: %s\n", m.text);
    c[1] = tg_cfg("limit", sim_chip, "8", EF_GPIO_IN);
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
    EF_CHECK(tg_has(&m, "limit") && tg_has(&m, "no such offset"));
    printf("sim_errors: %s\n", m.text);
    EF_CHECK_EQ(tg_fd_count(), fds);

    /* A line the kernel hog holds: the message names the hog's consumer; the line requested
     * before it is released again. */
    c[1] = tg_cfg("hogged", sim_chip, "HOGGED", EF_GPIO_OUT);
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
    snprintf(want, sizeof want, "gpio: hogged (%s:7): held by '" SIM_HOG_BY "'", sim_name);
    EF_CHECK(tg_has(&m, want));
    printf("sim_errors: %s\n", m.text);
    EF_CHECK_EQ(g.open, 0);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 0);
    EF_CHECK_EQ(tg_fd_count(), fds);
    c[1] = tg_cfg("hogged", sim_chip, "7", EF_GPIO_IN); /* as an input, by offset: the same */
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
    EF_CHECK(tg_has(&m, "held by '" SIM_HOG_BY "'"));

    /* The same line twice, in other spellings: both entries named. */
    c[1] = tg_cfg("again", SIM_LABEL, "0", EF_GPIO_IN);
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_ARG);
    snprintf(want, sizeof want, "estop and again both name %s:0", sim_name);
    EF_CHECK(tg_has(&m, want));
    printf("sim_errors: %s\n", m.text);
    ef_gpio_line_cfg_t d[3] = {tg_cfg(NULL, sim_chip, "ENABLE", EF_GPIO_OUT),
                               tg_cfg(NULL, sim_chip, "3", EF_GPIO_OUT),
                               tg_cfg(NULL, sim_name, "2", EF_GPIO_OUT)};
    EF_CHECK_EQ(ef_gpio_open(&g, d, 3, &m), EF_ERR_ARG);
    EF_CHECK(tg_has(&m, "line 0 and line 2"));
    EF_CHECK_EQ(tg_gpioinfo_ours(), 0);
    EF_CHECK_EQ(tg_fd_count(), fds);

    /* An unknown chip after a good one. */
    c[1] = tg_cfg("other", "gpiochip999", "0", EF_GPIO_IN);
    EF_CHECK_EQ(ef_gpio_open(&g, c, 2, &m), EF_ERR_IO);
    EF_CHECK(tg_has(&m, "gpio: other: chip 'gpiochip999': no such chip"));
    EF_CHECK_EQ(tg_fd_count(), fds);

    /* A line another set of this process holds: held by "evenfeed". */
    EF_CHECK_EQ(ef_gpio_open(&g, c, 1, &m), EF_OK);
    ef_gpio_line_cfg_t e = tg_cfg("estop2", sim_name, "0", EF_GPIO_IN);
    EF_CHECK_EQ(ef_gpio_open(&h, &e, 1, &m), EF_ERR_IO);
    EF_CHECK(tg_has(&m, "held by '" EF_GPIO_CONSUMER "'"));
    /* Opening a set that is open. */
    EF_CHECK_EQ(ef_gpio_open(&g, c, 1, &m), EF_ERR_STATE);
    EF_CHECK_EQ(g.open, 1);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 1);
    ef_gpio_close(&g);

    /* At most EF_GPIO_MAX_SETS sets (the registry of ef_gpio_safe_all()). */
    ef_gpio_t s[EF_GPIO_MAX_SETS + 1];
    char off[8];
    for (unsigned i = 0; i <= EF_GPIO_MAX_SETS; i++) {
        snprintf(off, sizeof off, "%u", i);
        ef_gpio_line_cfg_t one = tg_cfg("one", sim_chip, off, EF_GPIO_IN);
        int rc = ef_gpio_open(&s[i], &one, 1, &m);
        EF_CHECK_EQ(rc, i < EF_GPIO_MAX_SETS ? EF_OK : EF_ERR_FULL);
    }
    EF_CHECK_EQ(tg_gpioinfo_ours(), EF_GPIO_MAX_SETS);
    for (unsigned i = 0; i <= EF_GPIO_MAX_SETS; i++)
        ef_gpio_close(&s[i]);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 0);
    EF_CHECK_EQ(tg_fd_count(), fds);
}

/* A pulse of about width_ns on line off, its two edges written to gpio-sim's pull file
 * back to back (descriptor opened before); returns the width it had between the writes. */
static uint64_t tg_sim_pulse(unsigned off, uint64_t width_ns, uint64_t *t_start)
{
    char p[300];
    int fd = open(tg_sim_path(p, sizeof p, off, "pull"), O_WRONLY);
    if (fd < 0)
        return UINT64_MAX;
    uint64_t t0 = tg_now_ns();
    ssize_t a = pwrite(fd, "pull-up", 7, 0);
    tg_sleep_until(t0 + width_ns);
    uint64_t t1 = tg_now_ns();
    ssize_t b = pwrite(fd, "pull-down", 9, 0);
    close(fd);
    if (t_start)
        *t_start = t0;
    return a == 7 && b == 9 ? t1 - t0 : UINT64_MAX;
}

static void t_sim_debounce(void)
{
    if (!tg_sim_args())
        return;
    const uint32_t db_us = 5000;
    ef_gpio_t g;
    ef_msg_t m;
    uint8_t v;
    ef_gpio_line_cfg_t c[2] = {tg_cfg("estop", sim_chip, "ESTOP", EF_GPIO_IN),
                               tg_cfg("limit", sim_chip, "LIMIT", EF_GPIO_IN)};
    c[0].debounce_us = db_us;
    tg_sim_pull(SIM_ESTOP, 0);
    tg_sim_pull(SIM_LIMIT, 0);
    int rc = ef_gpio_open(&g, c, 2, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "ef_gpio_open: %s\n", m.text);
        return;
    }
    tg_log_t *log = calloc(1, sizeof *log);

    /* A pulse of ~200 us on the debounced input: ignored, counted as rejected. An attempt
     * is made again (up to 5) when it does not test that: the guest was too slow to write
     * the two edges within half the debounce, or the kernel's timestamps made the pulse last
     * the debounce (UML timestamps edges at its 100 Hz tick, TG_EDGE_DELAY_NS: a pulse
     * across a tick lasts up to 10 ms for the kernel; the change reported is then right). */
    uint64_t w = UINT64_MAX, t0 = 0;
    int verdict = 0; /* 1: ignored and rejected; -1: wrong */
    for (int i = 0; i < 5 && verdict == 0; i++) {
        uint64_t edges0 = g.l[0].edges, rej0 = g.l[0].rejected;
        memset(log, 0, sizeof *log);
        w = tg_sim_pulse(SIM_ESTOP, 200000u, &t0);
        tg_collect(&g, t0 + 60000000u, log);
        printf("sim_debounce: pulse of %.3f ms on estop: %llu edge(s), %llu rejected\n",
               (double)w / 1e6, (unsigned long long)(g.l[0].edges - edges0),
               (unsigned long long)(g.l[0].rejected - rej0));
        tg_print("pulse", log, t0);
        if (log->rc != EF_OK || w == UINT64_MAX) {
            verdict = -1;
        } else if (tg_count(log, 0) == 0) {
            verdict = g.l[0].edges > edges0 && g.l[0].rejected > rej0 ? 1 : -1;
        } else if (log->n == 2 && log->s[0].ev.value == 1 && log->s[1].ev.value == 0 &&
                   log->s[1].ev.t_ns - log->s[0].ev.t_ns >= db_us * 1000u) {
            printf("sim_debounce: the kernel's timestamps stretched the pulse: again\n");
        } else if (w < db_us * 1000u / 2) {
            verdict = -1;
        }
    }
    EF_CHECK_EQ(verdict, 1);
    EF_CHECK(w < db_us * 1000u / 2);
    EF_CHECK(ef_gpio_get(&g, 0, &v) == EF_OK && v == 0);

    /* The same pulse on the input without debounce: reported, up then down. */
    memset(log, 0, sizeof *log);
    w = tg_sim_pulse(SIM_LIMIT, 200000u, &t0);
    tg_collect(&g, t0 + 60000000u, log);
    tg_print("pulse without debounce", log, t0);
    EF_CHECK_EQ(log->rc, EF_OK);
    EF_CHECK_EQ(tg_count(log, 1), 2);
    if (log->n == 2) {
        EF_CHECK(log->s[0].ev.line == 1 && log->s[0].ev.value == 1);
        EF_CHECK(log->s[1].ev.line == 1 && log->s[1].ev.value == 0);
        EF_CHECK(log->s[0].ev.t_ns >= t0);
    }
    EF_CHECK(ef_gpio_get(&g, 1, &v) == EF_OK && v == 0);

    /* A 20 ms press: reported once, with the time of its first edge, after the debounce;
     * its release likewise. ef_gpio_process's next_us says when the interval ends. */
    uint64_t rej = g.l[0].rejected;
    memset(log, 0, sizeof *log);
    uint64_t ta = tg_now_ns();
    EF_CHECK_EQ(tg_sim_pull(SIM_ESTOP, 1), 0);
    uint64_t tb = tg_now_ns();
    tg_collect(&g, ta + 20000000u, log);
    uint64_t tc = tg_now_ns();
    EF_CHECK_EQ(tg_sim_pull(SIM_ESTOP, 0), 0);
    uint64_t td = tg_now_ns();
    tg_collect(&g, tc + 100000000u, log);
    tg_print("20 ms press", log, ta);
    printf("sim_debounce: press written in %.3f ms, release in %.3f ms; next_us %u..%u\n",
           (double)(tb - ta) / 1e6, (double)(td - tc) / 1e6, log->next_min, log->next_max);
    EF_CHECK_EQ(log->rc, EF_OK);
    EF_CHECK_EQ(tg_count(log, 0), 2);
    if (log->n == 2) {
        const tg_seen_t *p = &log->s[0], *r = &log->s[1];
        EF_CHECK(p->ev.line == 0 && p->ev.value == 1);
        EF_CHECK(r->ev.line == 0 && r->ev.value == 0);
        /* The press's time is the kernel's time of its edge (after the write, within the
         * kernel's delay), not the end of the debounce interval: it was taken from the ring
         * only a debounce interval after that time. */
        EF_CHECK(p->ev.t_ns >= ta && p->ev.t_ns <= tb + TG_EDGE_DELAY_NS);
        EF_CHECK(p->seen_ns >= p->ev.t_ns + db_us * 1000u);
        EF_CHECK(p->seen_ns < p->ev.t_ns + db_us * 1000u + TG_SLACK_NS);
        EF_CHECK(r->ev.t_ns >= tc && r->ev.t_ns <= td + TG_EDGE_DELAY_NS);
        EF_CHECK(r->seen_ns >= r->ev.t_ns + db_us * 1000u);
        EF_CHECK(r->seen_ns < r->ev.t_ns + db_us * 1000u + TG_SLACK_NS);
        printf("sim_debounce: press at +%.3f ms from its write, reported %.3f ms after it\n",
               (double)(p->ev.t_ns - ta) / 1e6, (double)(p->seen_ns - p->ev.t_ns) / 1e6);
    }
    EF_CHECK(log->next_seen && log->next_max <= db_us && log->next_min > 0);
    EF_CHECK_EQ(g.l[0].rejected, rej); /* a clean press rejects nothing */
    EF_CHECK(ef_gpio_get(&g, 0, &v) == EF_OK && v == 0);
    free(log);
    ef_gpio_close(&g);
}

/* The level of each sim line at the moment libgpiod released it (-1: not released). Found
 * by wrapping libgpiod's gpiod_line_release() (the real one does the work): gpio-sim sets a
 * released line back to its pull, so what ef_gpio_close() drove is visible only just before
 * the release. */
static int tg_rel_level[SIM_LINES];
static int tg_rel_watch;

void gpiod_line_release(struct gpiod_line *line)
{
    static void (*real)(struct gpiod_line *);
    if (!real)
        *(void **)&real = dlsym(RTLD_NEXT, "gpiod_line_release");
    if (tg_rel_watch && gpiod_line_is_requested(line) && gpiod_line_offset(line) < SIM_LINES)
        tg_rel_level[gpiod_line_offset(line)] = tg_sim_value(gpiod_line_offset(line));
    if (real)
        real(line);
}

static void tg_on_signal(int sig)
{
    (void)sig;
    ef_gpio_safe_all();
}

static void t_sim_safe(void)
{
    if (!tg_sim_args())
        return;
    ef_gpio_t a, b;
    ef_msg_t m;
    uint8_t v;
    /* Two sets: enable (safe 0) and brake (active-low, safe 0 = high); aux (safe 1). */
    ef_gpio_line_cfg_t ca[3] = {tg_cfg("enable", sim_chip, "ENABLE", EF_GPIO_OUT),
                                tg_cfg("brake", sim_chip, "BRAKE", EF_GPIO_OUT),
                                tg_cfg("estop", sim_chip, "ESTOP", EF_GPIO_IN)};
    ca[1].active_low = 1;
    ef_gpio_line_cfg_t cb = tg_cfg("aux", sim_name, "6", EF_GPIO_OUT);
    cb.safe = 1;
    for (unsigned k = 0; k < SIM_LINES; k++)
        if (k != SIM_HOG)
            tg_sim_pull(k, 0);
    EF_CHECK_EQ(ef_gpio_open(&a, ca, 3, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_open(&b, &cb, 1, &m), EF_OK);
    if (!a.open || !b.open) {
        fprintf(stderr, "ef_gpio_open: %s\n", m.text);
        ef_gpio_close(&a);
        ef_gpio_close(&b);
        return;
    }

    /* Active, then ef_gpio_safe_all() from a signal handler: both sets safe. */
    struct sigaction sa, old;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = tg_on_signal;
    sigemptyset(&sa.sa_mask);
    EF_CHECK_EQ(sigaction(SIGUSR1, &sa, &old), 0);
    EF_CHECK_EQ(ef_gpio_set(&a, 0, 1, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_set(&a, 1, 1, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_set(&b, 0, 0, &m), EF_OK);
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 1);
    EF_CHECK_EQ(tg_sim_value(SIM_BRAKE), 0);
    EF_CHECK_EQ(tg_sim_value(SIM_AUX), 0);
    errno = 1234;
    raise(SIGUSR1);
    EF_CHECK_EQ(errno, 1234);
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 0);
    EF_CHECK_EQ(tg_sim_value(SIM_BRAKE), 1);
    EF_CHECK_EQ(tg_sim_value(SIM_AUX), 1);
    EF_CHECK(ef_gpio_get(&a, 0, &v) == EF_OK && v == 0);
    EF_CHECK(ef_gpio_get(&b, 0, &v) == EF_OK && v == 1);

    /* ef_gpio_safe(): one set only. */
    EF_CHECK_EQ(ef_gpio_set(&a, 0, 1, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_set(&b, 0, 0, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_safe(&a, &m), EF_OK);
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 0);
    EF_CHECK_EQ(tg_sim_value(SIM_AUX), 0);

    /* ef_gpio_close(): safe before release (seen at the release), and out of the registry. */
    for (unsigned k = 0; k < SIM_LINES; k++)
        tg_rel_level[k] = -1;
    EF_CHECK_EQ(ef_gpio_set(&a, 0, 1, &m), EF_OK);
    EF_CHECK_EQ(ef_gpio_set(&a, 1, 1, &m), EF_OK);
    tg_rel_watch = 1;
    ef_gpio_close(&a);
    EF_CHECK_EQ(tg_rel_level[SIM_ENABLE], 0);
    EF_CHECK_EQ(tg_rel_level[SIM_BRAKE], 1);
    EF_CHECK_EQ(tg_rel_level[SIM_ESTOP], 0); /* the input was released too */
    EF_CHECK_EQ(tg_rel_level[SIM_AUX], -1);
    /* Released, gpio-sim shows the pulls again. */
    EF_CHECK_EQ(tg_sim_value(SIM_ENABLE), 0);
    EF_CHECK_EQ(tg_sim_value(SIM_BRAKE), 0);
    /* The closed set is out of the registry: ef_gpio_safe_all() drives b only. */
    raise(SIGUSR1);
    EF_CHECK_EQ(tg_sim_value(SIM_AUX), 1);
    EF_CHECK_EQ(ef_gpio_set(&b, 0, 0, &m), EF_OK);
    ef_gpio_close(&b);
    tg_rel_watch = 0;
    EF_CHECK_EQ(tg_rel_level[SIM_AUX], 1);
    EF_CHECK_EQ(tg_gpioinfo_ours(), 0);
    raise(SIGUSR1); /* nothing open */
    EF_CHECK_EQ(sigaction(SIGUSR1, &old, NULL), 0);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"offline", t_offline_args},
        {"offline", t_offline_nochip},
        {"offline", t_offline_closed},
        {"sim_open CHIP SYSDIR", t_sim_open},
        {"sim_errors CHIP SYSDIR", t_sim_errors},
        {"sim_debounce CHIP SYSDIR", t_sim_debounce},
        {"sim_safe CHIP SYSDIR", t_sim_safe},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
