/* SPDX-License-Identifier: Apache-2.0 */
/* Machine I/O on GPIO: the machine file, e-stop / alarm supervision with its latch, feed
 * hold, enable outputs, the charge-pump thread, program outputs (ef_mio.h, docs/io.md). */
#include <ctype.h>
#include <errno.h>
#include <sched.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "evenfeed/host/io/ef_mio.h"

/* Defaults (docs/io.md). */
#define MIO_DEBOUNCE_US      2000u /* a 200 us glitch is ignored, a 5 ms press counts */
#define MIO_PUMP_HZ          500u
#define MIO_PUMP_WATCHDOG_MS 250u
#define MIO_STOP_MS          2000u

static uint64_t mio_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* ------------------------------------------------------------------ machine file */

/* Where a parse is: file and line for messages, the current section. */
typedef struct {
    const char *path;
    unsigned line;
    char sec[32];
    char chip[64];        /* [gpio] chip: the default for lines without CHIP: */
    uint32_t debounce_us; /* [gpio] debounce_ms */
    /* per-section settings applied when the section ends */
    char lines[EF_MIO_MAX_OUTS][128];
    unsigned n_lines;
    int contact_nc;    /* -1 unset, else 1 = nc, 0 = no */
    int active_low;    /* -1 unset */
    int bias;          /* -1 unset */
    long debounce;     /* -1 unset, else us */
    unsigned sec_line; /* where the section began */
} mio_parse_t;

static int mio_err(ef_msg_t *m, const mio_parse_t *P, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static int mio_err(ef_msg_t *m, const mio_parse_t *P, const char *fmt, ...)
{
    char t[300];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t, sizeof t, fmt, ap);
    va_end(ap);
    return ef_fail(m, EF_ERR_ARG, "%s:%u: %s", P->path, P->line, t);
}

/* Strip spaces at both ends, in place. */
static char *mio_trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t n = strlen(s);
    while (n > 0 && isspace((unsigned char)s[n - 1]))
        s[--n] = 0;
    return s;
}

/* A whole number in [lo, hi]. */
static int mio_num(const char *v, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (errno || end == v || *end || x < lo || x > hi)
        return -1;
    *out = x;
    return 0;
}

/* Add one line to the config: spec "CHIP:LINE" or "LINE" (the [gpio] chip). */
static int mio_add(ef_mio_cfg_t *c, mio_parse_t *P, const char *spec, const char *what, int dir,
                   int active_low, int bias, uint32_t debounce, int *idx, ef_msg_t *m)
{
    ef_gpio_line_cfg_t L;
    memset(&L, 0, sizeof L);
    switch (ef_gpio_spec(&L, spec, P->chip)) {
    case EF_GPIO_SPEC_PARTS:
        return mio_err(m, P, "line '%s': CHIP:LINE, both parts non-empty", spec);
    case EF_GPIO_SPEC_NOCHIP:
        return mio_err(m, P, "line '%s' names no chip: write CHIP:%s or set chip in [gpio]", spec,
                       spec);
    case EF_GPIO_SPEC_LONG:
        return mio_err(m, P, "line '%s': name too long", spec);
    default:
        break;
    }
    L.dir = (uint8_t)dir;
    L.active_low = (uint8_t)active_low;
    L.bias = (uint8_t)bias;
    L.debounce_us = dir == EF_GPIO_IN ? debounce : 0;
    L.safe = 0;
    /* one line, one function */
    const ef_gpio_line_cfg_t *all[EF_GPIO_MAX_LINES + 1];
    unsigned na = 0;
    for (unsigned k = 0; k < c->n; k++)
        all[na++] = &c->lines[k];
    if (c->pump >= 0)
        all[na++] = &c->pump_line;
    for (unsigned k = 0; k < na; k++)
        if (!strcmp(all[k]->chip, L.chip) && !strcmp(all[k]->line, L.line)) {
            char t[160];
            snprintf(t, sizeof t, "%s:%s", L.chip, L.line);
            return mio_err(m, P, "line %s is already wired to %s", t, all[k]->what);
        }
    if (!strcmp(what, "charge_pump")) {
        L.what = "charge_pump";
        c->pump_line = L;
        *idx = 0;
        return EF_OK;
    }
    if (c->n >= EF_GPIO_MAX_LINES)
        return mio_err(m, P, "more than %d lines", EF_GPIO_MAX_LINES);
    snprintf(c->names[c->n], sizeof c->names[c->n], "%s", what);
    L.what = c->names[c->n];
    c->lines[c->n] = L;
    *idx = (int)c->n++;
    return EF_OK;
}

/* The section in P ends: wire its lines. */
static int mio_end_section(ef_mio_cfg_t *c, mio_parse_t *P, ef_msg_t *m)
{
    const char *s = P->sec;
    if (!s[0] || !strcmp(s, "gpio"))
        return EF_OK;
    unsigned save = P->line;
    P->line = P->sec_line;
    int rc = EF_OK;
    uint32_t deb = P->debounce >= 0 ? (uint32_t)P->debounce : P->debounce_us;
    int bias = P->bias >= 0 ? P->bias : EF_GPIO_BIAS_AS_IS;
    if (!strcmp(s, "outputs")) {
        int al = P->active_low > 0;
        for (unsigned p = 0; p < EF_MIO_MAX_OUTS && rc == EF_OK; p++) {
            if (!P->lines[p][0])
                continue;
            char what[32];
            snprintf(what, sizeof what, "out.p%u", p);
            rc = mio_add(c, P, P->lines[p], what, EF_GPIO_OUT, al, bias, 0, &c->out[p], m);
        }
        P->line = save;
        return rc;
    }
    if (P->n_lines == 0) {
        rc = mio_err(m, P, "[%s] wires no line (line = ...)", s);
        P->line = save;
        return rc;
    }
    if (!strcmp(s, "estop") || !strcmp(s, "feed_hold") || !strcmp(s, "cycle_start")) {
        if (P->n_lines > 1)
            rc = mio_err(m, P, "[%s] is one input (line = ...)", s);
        int nc = P->contact_nc >= 0 ? P->contact_nc : !strcmp(s, "estop");
        int *idx = !strcmp(s, "estop") ? &c->estop : !strcmp(s, "feed_hold") ? &c->hold : &c->start;
        /* A normally closed contact reads high while closed: active (open) is low. */
        if (rc == EF_OK)
            rc = mio_add(c, P, P->lines[0], s, EF_GPIO_IN, nc, bias, deb, idx, m);
    } else if (!strcmp(s, "alarm")) {
        int nc = P->contact_nc > 0;
        for (unsigned k = 0; k < P->n_lines && rc == EF_OK; k++) {
            char what[32];
            snprintf(what, sizeof what, "alarm.%u", k + 1);
            rc = mio_add(c, P, P->lines[k], what, EF_GPIO_IN, nc, bias, deb, &c->alarm[k], m);
        }
        c->n_alarm = P->n_lines;
    } else if (!strcmp(s, "enable")) {
        int al = P->active_low > 0;
        for (unsigned k = 0; k < P->n_lines && rc == EF_OK; k++) {
            char what[32];
            snprintf(what, sizeof what, "enable.%u", k + 1);
            rc = mio_add(c, P, P->lines[k], what, EF_GPIO_OUT, al, bias, 0, &c->enable[k], m);
        }
        c->n_enable = P->n_lines;
    } else if (!strcmp(s, "charge_pump")) {
        if (P->n_lines > 1)
            rc = mio_err(m, P, "[%s] is one output (line = ...)", s);
        if (rc == EF_OK)
            rc =
                mio_add(c, P, P->lines[0], s, EF_GPIO_OUT, P->active_low > 0, bias, 0, &c->pump, m);
    }
    P->line = save;
    return rc;
}

static const char *const mio_sections[] = {
    "gpio", "estop", "enable", "alarm", "feed_hold", "cycle_start", "charge_pump", "outputs", NULL};

/* Split a value into words (lines = A B C). */
static int mio_words(mio_parse_t *P, char *v, unsigned max, ef_msg_t *m)
{
    P->n_lines = 0;
    for (char *w = strtok(v, " \t,"); w; w = strtok(NULL, " \t,")) {
        if (P->n_lines >= max)
            return mio_err(m, P, "at most %u lines here", max);
        if (strlen(w) >= sizeof P->lines[0])
            return mio_err(m, P, "line '%s' too long", w);
        snprintf(P->lines[P->n_lines++], sizeof P->lines[0], "%s", w);
    }
    if (P->n_lines == 0)
        return mio_err(m, P, "no line given");
    return EF_OK;
}

/* One key = value of the current section. */
static int mio_key(ef_mio_cfg_t *c, mio_parse_t *P, const char *k, char *v, ef_msg_t *m)
{
    const char *s = P->sec;
    long x;
    if (!s[0])
        return mio_err(m, P, "'%s' before any [section]", k);
    if (!strcmp(s, "gpio")) {
        if (!strcmp(k, "chip")) {
            if (!v[0] || strlen(v) >= sizeof P->chip || strchr(v, ':'))
                return mio_err(m, P, "chip '%s': a chip name, path, number or label", v);
            snprintf(P->chip, sizeof P->chip, "%s", v);
            return EF_OK;
        }
        if (!strcmp(k, "debounce_ms")) {
            if (mio_num(v, 0, 1000, &x))
                return mio_err(m, P, "debounce_ms '%s': 0..1000", v);
            P->debounce_us = (uint32_t)x * 1000u;
            return EF_OK;
        }
        return mio_err(m, P, "unknown key '%s' in [gpio] (chip, debounce_ms)", k);
    }
    if (!strcmp(s, "outputs")) {
        if ((k[0] == 'p' || k[0] == 'P') && !mio_num(k + 1, 0, EF_MIO_MAX_OUTS - 1, &x)) {
            if (P->lines[x][0])
                return mio_err(m, P, "output %s given twice", k);
            if (!v[0] || strchr(v, ' ') || strlen(v) >= sizeof P->lines[0])
                return mio_err(m, P, "%s = '%s': one line", k, v);
            snprintf(P->lines[x], sizeof P->lines[0], "%s", v);
            return EF_OK;
        }
        if (!strcmp(k, "active")) {
            if (strcmp(v, "high") && strcmp(v, "low"))
                return mio_err(m, P, "active '%s': high or low", v);
            P->active_low = !strcmp(v, "low");
            return EF_OK;
        }
        return mio_err(m, P, "unknown key '%s' in [outputs] (p0..p7, active)", k);
    }
    int input = strcmp(s, "enable") && strcmp(s, "charge_pump");
    if (!strcmp(k, "line") || !strcmp(k, "lines")) {
        unsigned max = !strcmp(s, "enable") || !strcmp(s, "alarm") ? EF_MIO_MAX_AXES : 1;
        return mio_words(P, v, max, m);
    }
    if (input && !strcmp(k, "contact")) {
        if (strcmp(v, "nc") && strcmp(v, "no"))
            return mio_err(m, P, "contact '%s': nc (normally closed) or no (normally open)", v);
        P->contact_nc = !strcmp(v, "nc");
        return EF_OK;
    }
    if (!input && !strcmp(k, "active")) {
        if (strcmp(v, "high") && strcmp(v, "low"))
            return mio_err(m, P, "active '%s': high or low", v);
        P->active_low = !strcmp(v, "low");
        return EF_OK;
    }
    if (!strcmp(k, "bias")) {
        static const char *const b[] = {"as-is", "disable", "pull-up", "pull-down"};
        for (int i = 0; i < 4; i++)
            if (!strcmp(v, b[i])) {
                P->bias = i;
                return EF_OK;
            }
        return mio_err(m, P, "bias '%s': as-is, disable, pull-up or pull-down", v);
    }
    if (input && !strcmp(k, "debounce_ms")) {
        if (mio_num(v, 0, 1000, &x))
            return mio_err(m, P, "debounce_ms '%s': 0..1000", v);
        P->debounce = x * 1000;
        return EF_OK;
    }
    if (!strcmp(s, "estop") && !strcmp(k, "latch")) {
        if (!v[0] || strlen(v) >= sizeof c->latch)
            return mio_err(m, P, "latch '%s': a file path", v);
        snprintf(c->latch, sizeof c->latch, "%s", v);
        return EF_OK;
    }
    /* the whole-machine numbers: section, key, range, field */
    const struct {
        const char *sec, *key;
        long lo, hi;
        uint32_t *to;
    } nums[] = {
        {"estop", "stop_timeout_ms", 1, 60000, &c->stop_ms},
        {"charge_pump", "hz", 1, 5000, &c->pump_hz},
        {"charge_pump", "watchdog_ms", 10, 10000, &c->pump_watchdog_ms},
    };
    for (size_t i = 0; i < sizeof nums / sizeof nums[0]; i++) {
        if (strcmp(s, nums[i].sec) || strcmp(k, nums[i].key))
            continue;
        if (mio_num(v, nums[i].lo, nums[i].hi, &x))
            return mio_err(m, P, "%s '%s': %ld..%ld", k, v, nums[i].lo, nums[i].hi);
        *nums[i].to = (uint32_t)x;
        return EF_OK;
    }
    char t[64];
    snprintf(t, sizeof t, "[%s]", s);
    return mio_err(m, P, "unknown key '%s' in %s (docs/io.md lists the keys)", k, t);
}

int ef_mio_cfg_load(ef_mio_cfg_t *c, const char *path, ef_msg_t *m)
{
    if (!c || !path)
        return ef_fail(m, EF_ERR_ARG, "machine file: missing argument");
    memset(c, 0, sizeof *c);
    c->estop = c->hold = c->start = c->pump = -1;
    for (int k = 0; k < EF_MIO_MAX_AXES; k++)
        c->enable[k] = c->alarm[k] = -1;
    for (int k = 0; k < EF_MIO_MAX_OUTS; k++)
        c->out[k] = -1;
    c->pump_hz = MIO_PUMP_HZ;
    c->pump_watchdog_ms = MIO_PUMP_WATCHDOG_MS;
    c->stop_ms = MIO_STOP_MS;
    snprintf(c->path, sizeof c->path, "%s", path);
    FILE *f = fopen(path, "r");
    if (!f)
        return ef_fail(m, EF_ERR_IO, "machine file %s: %s", path, strerror(errno));
    mio_parse_t P;
    memset(&P, 0, sizeof P);
    P.path = path;
    P.debounce_us = MIO_DEBOUNCE_US;
    P.contact_nc = P.active_low = P.bias = -1;
    P.debounce = -1;
    char seen[8] = {0};
    char buf[512];
    int rc = EF_OK;
    while (rc == EF_OK && fgets(buf, sizeof buf, f)) {
        P.line++;
        if (!strchr(buf, '\n') && !feof(f)) {
            rc = mio_err(m, &P, "line longer than %d characters", (int)sizeof buf - 2);
            break;
        }
        char *hash = strpbrk(buf, "#;");
        if (hash)
            *hash = 0;
        char *s = mio_trim(buf);
        if (!*s)
            continue;
        if (*s == '[') {
            char *e = strchr(s, ']');
            if (!e || mio_trim(e + 1)[0]) {
                rc = mio_err(m, &P, "'%s': a section is [name]", s);
                break;
            }
            *e = 0;
            char *name = mio_trim(s + 1);
            int which = -1;
            for (int i = 0; mio_sections[i]; i++)
                if (!strcmp(name, mio_sections[i]))
                    which = i;
            if (which < 0) {
                rc = mio_err(m, &P,
                             "unknown section [%s] (gpio, estop, enable, alarm, feed_hold, "
                             "cycle_start, charge_pump, outputs)",
                             name);
                break;
            }
            if (seen[which]) {
                rc = mio_err(m, &P, "section [%s] given twice", name);
                break;
            }
            if ((rc = mio_end_section(c, &P, m)) != EF_OK)
                break;
            seen[which] = 1;
            snprintf(P.sec, sizeof P.sec, "%s", name);
            P.sec_line = P.line;
            memset(P.lines, 0, sizeof P.lines);
            P.n_lines = 0;
            P.contact_nc = P.active_low = P.bias = -1;
            P.debounce = -1;
            continue;
        }
        char *eq = strchr(s, '=');
        if (!eq) {
            rc = mio_err(m, &P, "'%s': key = value expected", s);
            break;
        }
        *eq = 0;
        rc = mio_key(c, &P, mio_trim(s), mio_trim(eq + 1), m);
    }
    if (rc == EF_OK && ferror(f))
        rc = ef_fail(m, EF_ERR_IO, "machine file %s: read error", path);
    fclose(f);
    if (rc == EF_OK)
        rc = mio_end_section(c, &P, m);
    if (rc == EF_OK && c->n_enable > 0 && c->estop < 0)
        rc = ef_fail(m, EF_ERR_ARG,
                     "%s: [enable] without [estop]: an enable output needs an e-stop input "
                     "that can drop it",
                     path);
    if (rc == EF_OK && !c->latch[0]) {
        const char *dir = getenv("XDG_RUNTIME_DIR");
        const char *base = strrchr(path, '/');
        snprintf(c->latch, sizeof c->latch, "%s/evenfeed-%s.estop", dir && *dir ? dir : "/tmp",
                 base ? base + 1 : path);
    }
    if (rc != EF_OK) {
        ef_msg_t keep = *m;
        memset(c, 0, sizeof *c);
        *m = keep;
    }
    return rc;
}

/* ------------------------------------------------------------------ the I/O thread */

/* A trip (under mu): state, cause, latch file. */
static void mio_trip(ef_mio_t *io, int why, int line, uint64_t t_ns, const char *text)
{
    io->state = EF_MIO_TRIPPED;
    io->trip = why;
    io->trip_line = line;
    io->trip_ns = t_ns;
    io->trip_told = 0;
    snprintf(io->trip_text, sizeof io->trip_text, "%s", text);
    if (io->cfg.estop >= 0 || why == EF_MIO_TRIP_GPIO) {
        FILE *f = fopen(io->cfg.latch, "w");
        if (f) {
            time_t now = time(NULL);
            char ts[32];
            struct tm tmv;
            strftime(ts, sizeof ts, "%Y-%m-%dT%H:%M:%S", localtime_r(&now, &tmv));
            fprintf(f, "%s at %s\n", text, ts);
            fclose(f);
        }
    }
}

/* The name of cfg line k: "estop (gpiochip0:0)". */
static const char *mio_line_name(const ef_mio_t *io, int k, char *buf, unsigned n)
{
    const ef_gpio_t *g = io->cfg.lines[k].dir == EF_GPIO_IN ? &io->in : &io->out;
    return ef_gpio_name(g, (unsigned)io->set_of[k], buf, n);
}

/* The debounced logical value of cfg input k, 0 if not wired. */
static int mio_in(const ef_mio_t *io, int k)
{
    uint8_t v = 0;
    if (k >= 0)
        (void)ef_gpio_get(&io->in, (unsigned)io->set_of[k], &v);
    return v;
}

/* cfg index of input-set line j. */
static int mio_cfg_of_in(const ef_mio_t *io, unsigned j)
{
    for (unsigned k = 0; k < io->cfg.n; k++)
        if (io->cfg.lines[k].dir == EF_GPIO_IN && io->set_of[k] == (int8_t)j)
            return (int)k;
    return -1;
}

/* One round of the thread (under mu): inputs, trips, hold. */
static void mio_inputs(ef_mio_t *io, uint64_t now)
{
    if (io->in.n == 0)
        return;
    ef_msg_t gm = {{0}};
    uint32_t nx;
    int rc = ef_gpio_process(&io->in, now, &nx, &gm);
    /* Levels every EF_MIO_SAMPLE_US: a press of a few ms is seen twice or more, a glitch
     * shorter than the debounce at most once (a read per input: the cost under UML). */
    if (rc >= 0 && now - io->last_sample_ns >= (uint64_t)EF_MIO_SAMPLE_US * 1000u) {
        io->last_sample_ns = now;
        rc = ef_gpio_sample(&io->in, now, &gm);
    }
    if (rc < 0) {
        if (!io->gpio_err)
            snprintf(io->gpio_text, sizeof io->gpio_text, "%.190s", gm.text);
        io->gpio_err = 1;
        if (io->state == EF_MIO_ARMED) {
            char t[300];
            snprintf(t, sizeof t, "e-stop: GPIO read error (%.200s), taken as e-stop", gm.text);
            mio_trip(io, EF_MIO_TRIP_GPIO, -1, now, t);
        }
        return;
    }
    ef_gpio_event_t ev;
    char nm[160], t[200];
    while (ef_gpio_next_event(&io->in, &ev)) {
        int k = mio_cfg_of_in(io, ev.line);
        if (k < 0)
            continue;
        if (k == io->cfg.hold) {
            if (ev.value)
                io->hold = 1;
            else if (io->cfg.start < 0)
                io->hold = 0;
        } else if (k == io->cfg.start) {
            if (ev.value && !mio_in(io, io->cfg.hold))
                io->hold = 0;
        }
        if (io->state != EF_MIO_ARMED || !ev.value)
            continue;
        if (k == io->cfg.estop) {
            snprintf(t, sizeof t, "e-stop: input %s went active",
                     mio_line_name(io, k, nm, sizeof nm));
            mio_trip(io, EF_MIO_TRIP_ESTOP, k, ev.t_ns, t);
        }
        for (unsigned a = 0; a < io->cfg.n_alarm && io->state == EF_MIO_ARMED; a++)
            if (k == io->cfg.alarm[a]) {
                snprintf(t, sizeof t, "drive alarm: input %s went active",
                         mio_line_name(io, k, nm, sizeof nm));
                mio_trip(io, EF_MIO_TRIP_ALARM, k, ev.t_ns, t);
            }
    }
}

static void *mio_main(void *arg)
{
    ef_mio_t *io = arg;
    uint64_t half = io->cfg.pump >= 0 ? 500000000u / io->cfg.pump_hz : UINT64_MAX;
    uint64_t tick = (uint64_t)EF_MIO_TICK_US * 1000u;
    if (half < tick)
        tick = half;
    uint64_t next = mio_now_ns(), next_toggle = next;
    uint8_t level = 0;
    pthread_mutex_lock(&io->mu);
    while (!io->th_quit) {
        uint64_t now = mio_now_ns();
        io->ticks++;
        if (now > next + tick)
            io->late_ticks++;
        mio_inputs(io, now);
        /* The pump: while ARMED or TRIPPED, and only while the streamer's loop is alive (a
         * hung controller must look like a dead one to the drives' safety relay). */
        int run = io->state == EF_MIO_ARMED || io->state == EF_MIO_TRIPPED;
        int alive = now - io->alive_ns <= (uint64_t)io->cfg.pump_watchdog_ms * 1000000u;
        uint8_t want = level;
        if (!run || !alive) {
            want = 0;
        } else if (now >= next_toggle) {
            want = (uint8_t)!level;
            next_toggle += half;
            if (next_toggle < now)
                next_toggle = now + half;
        }
        if (io->cfg.pump >= 0 && want != level) {
            level = want;
            if (ef_gpio_set(&io->pump_g, 0, level, NULL) == EF_OK)
                io->pump_edges++;
        }
        if (!run)
            next_toggle = now;
        pthread_mutex_unlock(&io->mu);
        next += tick;
        if (next < now)
            next = now + tick; /* late by more than a tick: no burst to catch up */
        struct timespec ts = {(time_t)(next / 1000000000u), (long)(next % 1000000000u)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
            ;
        pthread_mutex_lock(&io->mu);
    }
    pthread_mutex_unlock(&io->mu);
    if (io->cfg.pump >= 0)
        (void)ef_gpio_set(&io->pump_g, 0, 0, NULL);
    return NULL;
}

/* ------------------------------------------------------------------ running */

int ef_mio_open(ef_mio_t *io, const ef_mio_cfg_t *c, ef_msg_t *m)
{
    if (!io || !c)
        return ef_fail(m, EF_ERR_ARG, "machine I/O: missing argument");
    memset(io, 0, sizeof *io);
    io->cfg = *c;
    io->trip_line = -1;
    /* the names live in the copy now; inputs and outputs in sets of their own */
    ef_gpio_line_cfg_t ins[EF_GPIO_MAX_LINES], outs[EF_GPIO_MAX_LINES];
    unsigned ni = 0, no = 0;
    for (unsigned k = 0; k < io->cfg.n; k++) {
        io->cfg.lines[k].what = io->cfg.names[k];
        if (io->cfg.lines[k].dir == EF_GPIO_IN) {
            io->set_of[k] = (int8_t)ni;
            ins[ni++] = io->cfg.lines[k];
        } else {
            io->set_of[k] = (int8_t)no;
            outs[no++] = io->cfg.lines[k];
        }
    }
    int rc = EF_OK;
    if (ni > 0 && (rc = ef_gpio_open(&io->in, ins, ni, m)) != EF_OK)
        return rc;
    if (no > 0 && (rc = ef_gpio_open(&io->out, outs, no, m)) != EF_OK) {
        ef_gpio_close(&io->in);
        return rc;
    }
    if (io->cfg.pump >= 0 && (rc = ef_gpio_open(&io->pump_g, &io->cfg.pump_line, 1, m)) != EF_OK) {
        ef_gpio_close(&io->out);
        ef_gpio_close(&io->in);
        return rc;
    }
    io->state = EF_MIO_SAFE;
    pthread_mutex_init(&io->mu, NULL);
    if (pthread_create(&io->th, NULL, mio_main, io) != 0) {
        pthread_mutex_destroy(&io->mu);
        ef_gpio_close(&io->pump_g);
        ef_gpio_close(&io->out);
        ef_gpio_close(&io->in);
        io->state = EF_MIO_CLOSED;
        return ef_fail(m, EF_ERR_IO, "machine I/O: cannot start its I/O thread");
    }
    io->th_started = 1;
    /* Real-time priority where the process may have it (root, CAP_SYS_NICE): the samples
     * must come every tick even while the streamer and its neighbours keep the CPU busy
     * (a 5 ms press between two late samples, merged into one event, would be lost). */
    struct sched_param sp = {.sched_priority = EF_MIO_RT_PRIO};
    io->rt = pthread_setschedparam(io->th, SCHED_FIFO, &sp) == 0;
    return EF_OK;
}

/* Enable outputs to v. */
static int mio_enable(ef_mio_t *io, int v, ef_msg_t *m)
{
    int rc = EF_OK;
    for (unsigned k = 0; k < io->cfg.n_enable; k++) {
        int r = ef_gpio_set(&io->out, (unsigned)io->set_of[io->cfg.enable[k]], (uint8_t)v, m);
        if (r != EF_OK && rc == EF_OK)
            rc = r;
    }
    return rc;
}

int ef_mio_arm(ef_mio_t *io, ef_msg_t *m)
{
    if (!io || io->state == EF_MIO_CLOSED)
        return ef_fail(m, EF_ERR_STATE, "machine I/O: not open");
    /* Two thread rounds at least, so the levels are this moment's. */
    pthread_mutex_lock(&io->mu);
    uint64_t t0 = io->ticks;
    pthread_mutex_unlock(&io->mu);
    for (int i = 0; i < 1000; i++) {
        pthread_mutex_lock(&io->mu);
        uint64_t t = io->ticks;
        pthread_mutex_unlock(&io->mu);
        if (t >= t0 + 2)
            break;
        struct timespec ts = {0, EF_MIO_TICK_US * 1000L};
        nanosleep(&ts, NULL);
    }
    pthread_mutex_lock(&io->mu);
    int rc = EF_OK;
    char nm[160];
    if (io->state != EF_MIO_SAFE) {
        rc = ef_fail(m, EF_ERR_STATE, "machine I/O: not ready to arm (state %d)", io->state);
    } else if (io->gpio_err) {
        rc = ef_fail(m, EF_ERR_ESTOP, "e-stop: reading the inputs failed, taken as e-stop: %s",
                     io->gpio_text);
    } else if (io->cfg.estop >= 0 && mio_in(io, io->cfg.estop)) {
        rc = ef_fail(m, EF_ERR_ESTOP, "e-stop: input %s is active: release it first",
                     mio_line_name(io, io->cfg.estop, nm, sizeof nm));
    } else {
        for (unsigned k = 0; k < io->cfg.n_alarm && rc == EF_OK; k++)
            if (mio_in(io, io->cfg.alarm[k]))
                rc = ef_fail(m, EF_ERR_ESTOP, "drive alarm: input %s is active",
                             mio_line_name(io, io->cfg.alarm[k], nm, sizeof nm));
    }
    if (rc == EF_OK && io->cfg.estop >= 0 && access(io->cfg.latch, F_OK) == 0) {
        char why[200] = "";
        FILE *f = fopen(io->cfg.latch, "r");
        if (f) {
            if (!fgets(why, sizeof why, f))
                why[0] = 0;
            fclose(f);
            why[strcspn(why, "\n")] = 0;
        }
        rc = ef_fail(m, EF_ERR_ESTOP,
                     "e-stop latched (%s): the input reads released; run `evenfeed io reset "
                     "--machine %s` to leave e-stop",
                     why[0] ? why : io->cfg.latch, io->cfg.path);
    }
    if (rc == EF_OK) {
        io->hold = mio_in(io, io->cfg.hold);
        io->alive_ns = mio_now_ns();
    }
    pthread_mutex_unlock(&io->mu);
    if (rc != EF_OK)
        return rc;
    if ((rc = mio_enable(io, 1, m)) != EF_OK) {
        (void)mio_enable(io, 0, NULL);
        return rc;
    }
    pthread_mutex_lock(&io->mu);
    io->state = EF_MIO_ARMED; /* from here on the thread trips, and the pump runs */
    io->trip = EF_MIO_TRIP_NONE;
    pthread_mutex_unlock(&io->mu);
    return EF_OK;
}

int ef_mio_process(ef_mio_t *io, uint32_t *next_us, ef_msg_t *m)
{
    if (next_us)
        *next_us = UINT32_MAX;
    if (!io || io->state == EF_MIO_CLOSED)
        return EF_OK;
    pthread_mutex_lock(&io->mu);
    io->alive_ns = mio_now_ns();
    int rc = EF_OK;
    if (io->state == EF_MIO_TRIPPED && !io->trip_told) {
        io->trip_told = 1;
        rc = ef_fail(m, EF_ERR_ESTOP, "%s", io->trip_text);
    }
    pthread_mutex_unlock(&io->mu);
    return rc;
}

int ef_mio_hold(const ef_mio_t *io)
{
    if (!io || io->state == EF_MIO_CLOSED)
        return 0;
    pthread_mutex_lock((pthread_mutex_t *)&io->mu);
    int h = io->hold;
    pthread_mutex_unlock((pthread_mutex_t *)&io->mu);
    return h;
}

int ef_mio_out(ef_mio_t *io, unsigned p, int value, ef_msg_t *m)
{
    if (!io || p >= EF_MIO_MAX_OUTS || io->cfg.out[p] < 0)
        return ef_fail(m, EF_ERR_ARG, "output P%u is not wired ([outputs] p%u = LINE)", p, p);
    return ef_gpio_set(&io->out, (unsigned)io->set_of[io->cfg.out[p]], (uint8_t)(value != 0), m);
}

int ef_mio_disarm(ef_mio_t *io, ef_msg_t *m)
{
    if (!io || io->state == EF_MIO_CLOSED)
        return EF_OK;
    pthread_mutex_lock(&io->mu);
    int was = io->state;
    if (was == EF_MIO_ARMED || was == EF_MIO_TRIPPED)
        io->state = EF_MIO_SAFE; /* the pump stops at the thread's next round */
    pthread_mutex_unlock(&io->mu);
    if (was != EF_MIO_ARMED && was != EF_MIO_TRIPPED)
        return EF_OK;
    ef_msg_t em = {{0}}, om = {{0}};
    int rc = mio_enable(io, 0, &em);
    int orc = io->out.n ? ef_gpio_safe(&io->out, &om) : EF_OK;
    if (rc != EF_OK)
        return ef_fail(m, EF_ERR_IO, "enable not confirmed off: %s (the charge pump stopped)",
                       em.text);
    if (orc != EF_OK)
        return ef_fail(m, EF_ERR_IO, "outputs not confirmed safe: %s (the charge pump stopped)",
                       om.text);
    return EF_OK;
}

void ef_mio_close(ef_mio_t *io)
{
    if (!io || io->state == EF_MIO_CLOSED)
        return;
    (void)ef_mio_disarm(io, NULL); /* closing: the lines are released safe next, or gone */
    if (io->th_started) {
        pthread_mutex_lock(&io->mu);
        io->th_quit = 1;
        pthread_mutex_unlock(&io->mu);
        pthread_join(io->th, NULL);
        pthread_mutex_destroy(&io->mu);
        io->th_started = 0;
    }
    ef_gpio_close(&io->pump_g);
    ef_gpio_close(&io->out);
    ef_gpio_close(&io->in);
    io->state = EF_MIO_CLOSED;
}

int ef_mio_state(const ef_mio_t *io)
{
    if (!io || io->state == EF_MIO_CLOSED)
        return EF_MIO_CLOSED;
    pthread_mutex_lock((pthread_mutex_t *)&io->mu);
    int st = io->state;
    pthread_mutex_unlock((pthread_mutex_t *)&io->mu);
    return st;
}

int ef_mio_reset(const ef_mio_cfg_t *c, ef_msg_t *m)
{
    if (!c)
        return ef_fail(m, EF_ERR_ARG, "io reset: missing argument");
    if (c->estop < 0)
        return ef_fail(m, EF_ERR_ARG, "io reset: %s wires no e-stop input", c->path);
    ef_gpio_line_cfg_t one = c->lines[c->estop]; /* the e-stop line alone */
    one.what = "estop";
    one.debounce_us = 0; /* the level now */
    ef_gpio_t g;
    int rc = ef_gpio_open(&g, &one, 1, m);
    if (rc != EF_OK)
        return rc;
    uint8_t v = 1;
    (void)ef_gpio_get(&g, 0, &v);
    char nm[160];
    ef_gpio_name(&g, 0, nm, sizeof nm);
    ef_gpio_close(&g);
    if (v)
        return ef_fail(m, EF_ERR_ESTOP,
                       "io reset: e-stop input %s is still active: release it first", nm);
    if (unlink(c->latch) != 0 && errno != ENOENT)
        return ef_fail(m, EF_ERR_IO, "io reset: latch %s: %s", c->latch, strerror(errno));
    return EF_OK;
}

int ef_mio_m_words(const char *text, int *codes, long *ps, int max)
{
    int n = 0;
    const char *t = text;
    while (t && n < max && (t = strchr(t, 'M')) != NULL) {
        char *end;
        long code = strtol(t + 1, &end, 10);
        t = end;
        if (code < 62 || code > 65 || (*end >= '0' && *end <= '9') || *end == '.')
            continue;
        /* its P: the next word, when it is one (the reader writes "M64 P1") */
        const char *q = end;
        while (*q == ' ')
            q++;
        codes[n] = (int)code;
        ps[n] = *q == 'P' ? strtol(q + 1, NULL, 10) : -1;
        n++;
    }
    return n;
}
