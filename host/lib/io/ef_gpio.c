/* SPDX-License-Identifier: Apache-2.0 */
/* GPIO lines through libgpiod 1.6: inputs with edge events and software debounce, outputs
 * with a safe state, and a registry of open sets for ef_gpio_safe_all(). */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gpiod.h>

#include "evenfeed/host/io/ef_gpio.h"

/* Events read from a line's descriptor at once: the v1 uAPI's kernel FIFO holds 16, so a
 * read that fills the buffer means the FIFO may have been full and dropped edges. */
#define EF_GPIO_READ_BATCH 16u
/* Reads per line and ef_gpio_process() call: bounds the work under an edge storm (what is
 * left is read next time; the level is read back meanwhile). */
#define EF_GPIO_READ_ROUNDS 8u

/* Open sets, for ef_gpio_safe_all(): a slot is taken at the end of a successful open and
 * cleared first thing in close, before anything is released. Lock-free atomics, so a signal
 * handler can read them. */
static ef_gpio_t *_Atomic gpio_sets[EF_GPIO_MAX_SETS];

/* Monotonic nanoseconds. */
static uint64_t gpio_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* The entry's name for messages before its line is known: cfg.what or "line k". */
static const char *gpio_what(const ef_gpio_line_cfg_t *c, unsigned k, char *buf, size_t n)
{
    if (c->what && c->what[0])
        return c->what;
    snprintf(buf, n, "line %u", k);
    return buf;
}

/* Whether s is a non-empty string of decimal digits. */
static int gpio_all_digits(const char *s)
{
    if (!*s)
        return 0;
    for (; *s; s++)
        if (*s < '0' || *s > '9')
            return 0;
    return 1;
}

/* Whether a fixed-size field holds a terminated string. */
static int gpio_terminated(const char *s, size_t n)
{
    return memchr(s, 0, n) != NULL;
}

/* libgpiod request flags for a line's configuration. */
static int gpio_flags(const ef_gpio_line_cfg_t *c)
{
    int f = 0;
    if (c->active_low)
        f |= GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW;
    switch (c->bias) {
    case EF_GPIO_BIAS_DISABLE:
        f |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE;
        break;
    case EF_GPIO_BIAS_PULL_UP:
        f |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP;
        break;
    case EF_GPIO_BIAS_PULL_DOWN:
        f |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN;
        break;
    default:
        break;
    }
    return f;
}

/* Whether g is in the registry. */
static int gpio_registered(const ef_gpio_t *g)
{
    for (unsigned i = 0; i < EF_GPIO_MAX_SETS; i++)
        if (atomic_load(&gpio_sets[i]) == g)
            return 1;
    return 0;
}

/* Put g in a free registry slot; 0 when all are taken. */
static int gpio_register(ef_gpio_t *g)
{
    for (unsigned i = 0; i < EF_GPIO_MAX_SETS; i++) {
        ef_gpio_t *expect = NULL;
        if (atomic_compare_exchange_strong(&gpio_sets[i], &expect, g))
            return 1;
    }
    return 0;
}

static void gpio_unregister(ef_gpio_t *g)
{
    for (unsigned i = 0; i < EF_GPIO_MAX_SETS; i++) {
        ef_gpio_t *expect = g;
        atomic_compare_exchange_strong(&gpio_sets[i], &expect, NULL);
    }
}

/* Release every requested line of g and close every chip (each once); leaves the
 * configuration and the counters, clears the handles. */
static void gpio_release(ef_gpio_t *g)
{
    for (unsigned k = 0; k < g->n; k++) {
        ef_gpio_line_t *L = &g->l[k];
        if (L->line && gpiod_line_is_requested((struct gpiod_line *)L->line))
            gpiod_line_release((struct gpiod_line *)L->line);
        L->line = NULL;
        L->fd = -1;
    }
    for (unsigned k = 0; k < g->n; k++) {
        struct gpiod_chip *c = (struct gpiod_chip *)g->l[k].chip;
        if (!c)
            continue;
        for (unsigned j = k; j < g->n; j++)
            if (g->l[j].chip == c)
                g->l[j].chip = NULL;
        gpiod_chip_close(c);
    }
}

/* Push a debounced change to the ring (a full ring drops the oldest). */
static void gpio_push(ef_gpio_t *g, unsigned k, uint8_t value, uint64_t t_ns)
{
    if (g->ev_count == EF_GPIO_EVQ) {
        g->ev_head = (g->ev_head + 1) % EF_GPIO_EVQ;
        g->ev_count--;
        g->ev_lost++;
    }
    ef_gpio_event_t *e = &g->evq[(g->ev_head + g->ev_count) % EF_GPIO_EVQ];
    e->line = (uint8_t)k;
    e->value = value;
    e->t_ns = t_ns;
    g->ev_count++;
}

/* Debounced value of line k takes its raw level (a change that held). */
static int gpio_commit(ef_gpio_t *g, unsigned k)
{
    ef_gpio_line_t *L = &g->l[k];
    if (L->raw == L->value)
        return 0;
    L->value = L->raw;
    gpio_push(g, k, L->value, L->t_raw_ns);
    return 1;
}

/* One edge of input k: the level is v (logical) from t_ns on. Returns the debounced changes
 * added. */
static int gpio_edge(ef_gpio_t *g, unsigned k, uint8_t v, uint64_t t_ns)
{
    ef_gpio_line_t *L = &g->l[k];
    uint64_t db = (uint64_t)L->cfg.debounce_us * 1000u;
    int added = 0;

    /* An event the level read at open (or after an overflow) already accounts for. */
    if (v == L->raw && t_ns <= L->t_raw_ns)
        return 0;
    L->edges++;
    /* A pending level that held until this edge has been stable long enough. */
    if (db && L->raw != L->value && t_ns >= L->t_raw_ns && t_ns - L->t_raw_ns >= db)
        added += gpio_commit(g, k);
    if (v == L->raw && g->sampled) {
        /* merged edges: the samples tell the level (ef_gpio_sample()); the kernel read it
         * still there at t_ns */
        if (t_ns > L->t_seen_ns)
            L->t_seen_ns = t_ns;
        return added;
    }
    if (v == L->raw) {
        /* The kernel reports the level it reads after the edge: the same level twice means
         * the line left it and came back in between (edges merged or lost). */
        if (db == 0) {
            L->raw = L->value = (uint8_t)!v;
            gpio_push(g, k, L->value, t_ns);
            L->raw = L->value = v;
            gpio_push(g, k, v, t_ns);
            L->t_raw_ns = t_ns;
            return added + 2;
        }
        L->rejected++;
        L->t_raw_ns = t_ns;
        return added;
    }
    if (L->raw != L->value)
        L->rejected++; /* the pending level did not last */
    L->raw = v;
    L->t_raw_ns = t_ns;
    if (t_ns > L->t_seen_ns)
        L->t_seen_ns = t_ns;
    if (db == 0)
        added += gpio_commit(g, k);
    return added;
}

/* Read what the kernel queued for input k and apply it; EF_ERR_IO on a failed read. */
static int gpio_drain(ef_gpio_t *g, unsigned k, uint64_t now_ns, int *added, ef_msg_t *m)
{
    ef_gpio_line_t *L = &g->l[k];
    struct gpiod_line_event ev[EF_GPIO_READ_BATCH];
    int doubt = 0;
    char nm[160];

    for (unsigned round = 0;; round++) {
        if (round == EF_GPIO_READ_ROUNDS) {
            doubt = 1;
            break;
        }
        int r = gpiod_line_event_read_fd_multiple(L->fd, ev, EF_GPIO_READ_BATCH);
        if (r < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK)
                break;
            if (errno == EINTR)
                continue;
            return ef_fail(m, EF_ERR_IO, "gpio: %s: reading edge events: %s",
                           ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
        }
        for (int i = 0; i < r; i++) {
            uint64_t t = (uint64_t)ev[i].ts.tv_sec * 1000000000u + (uint64_t)ev[i].ts.tv_nsec;
            uint8_t v = ev[i].event_type == GPIOD_LINE_EVENT_RISING_EDGE;
            *added += gpio_edge(g, k, v, t);
        }
        if ((unsigned)r < EF_GPIO_READ_BATCH)
            break;
        doubt = 1; /* a full batch: the kernel's FIFO may have overflowed */
    }
    if (doubt) {
        int v = gpiod_line_get_value((struct gpiod_line *)L->line);
        if (v < 0)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: reading the level: %s",
                           ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
        if ((uint8_t)v != L->raw)
            *added += gpio_edge(g, k, (uint8_t)v, now_ns > L->t_raw_ns ? now_ns : L->t_raw_ns);
    }
    return EF_OK;
}

/* Request line k (chip and line resolved) as configured; EF_ERR_IO with a message. */
static int gpio_request(ef_gpio_t *g, unsigned k, ef_msg_t *m)
{
    ef_gpio_line_t *L = &g->l[k];
    struct gpiod_line *line = (struct gpiod_line *)L->line;
    int flags = gpio_flags(&L->cfg);
    char nm[160];

    if (gpiod_line_is_used(line)) {
        const char *who = gpiod_line_consumer(line);
        if (who)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: held by '%s'",
                           ef_gpio_name(g, k, nm, sizeof nm), who);
        return ef_fail(m, EF_ERR_IO, "gpio: %s: in use (by a consumer without a label)",
                       ef_gpio_name(g, k, nm, sizeof nm));
    }
    if (L->cfg.dir == EF_GPIO_OUT) {
        L->cfg.safe = (uint8_t)(L->cfg.safe != 0);
        if (gpiod_line_request_output_flags(line, EF_GPIO_CONSUMER, flags, L->cfg.safe) < 0)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: output refused by the kernel: %s",
                           ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
        L->value = L->cfg.safe;
        return EF_OK;
    }
    if (gpiod_line_request_both_edges_events_flags(line, EF_GPIO_CONSUMER, flags) < 0)
        return ef_fail(m, EF_ERR_IO, "gpio: %s: input refused by the kernel: %s",
                       ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
    L->fd = gpiod_line_event_get_fd(line);
    int fl = L->fd >= 0 ? fcntl(L->fd, F_GETFL) : -1;
    if (fl < 0 || fcntl(L->fd, F_SETFL, fl | O_NONBLOCK) < 0)
        return ef_fail(m, EF_ERR_IO, "gpio: %s: event descriptor: %s",
                       ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
    int v = gpiod_line_get_value(line);
    if (v < 0)
        return ef_fail(m, EF_ERR_IO, "gpio: %s: reading the level: %s",
                       ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
    L->raw = L->value = (uint8_t)(v != 0);
    L->t_raw_ns = gpio_now_ns();
    return EF_OK;
}

/* Open (or share) the chip of entry k and find its line; EF_ERR_IO with a message. */
static int gpio_resolve(ef_gpio_t *g, unsigned k, ef_msg_t *m)
{
    ef_gpio_line_t *L = &g->l[k];
    const ef_gpio_line_cfg_t *c = &L->cfg;
    struct gpiod_chip *chip = NULL;
    char wb[32];
    const char *what = gpio_what(c, k, wb, sizeof wb);

    /* The same text as an earlier entry: its chip. */
    for (unsigned j = 0; j < k && !chip; j++)
        if (strcmp(g->l[j].cfg.chip, c->chip) == 0)
            chip = (struct gpiod_chip *)g->l[j].chip;
    if (!chip) {
        errno = 0;
        chip = gpiod_chip_open_lookup(c->chip);
        if (!chip) {
            int e = errno ? errno : ENOENT;
            int none = e == ENOENT || e == ENODEV || e == ENOTTY;
            return ef_fail(m, EF_ERR_IO, "gpio: %s: chip '%s': %s (gpiod_chip_open_lookup: %s)",
                           what, c->chip, none ? "no such chip" : "cannot open", strerror(e));
        }
        /* Another spelling of a chip already open ("0", "gpiochip0", a label, a path):
         * share that one, so one line has one libgpiod object. */
        for (unsigned j = 0; j < k; j++) {
            struct gpiod_chip *o = (struct gpiod_chip *)g->l[j].chip;
            if (o && strcmp(gpiod_chip_name(o), gpiod_chip_name(chip)) == 0) {
                gpiod_chip_close(chip);
                chip = o;
                break;
            }
        }
    }
    L->chip = chip;

    struct gpiod_line *line;
    if (gpio_all_digits(c->line)) {
        unsigned long off = strtoul(c->line, NULL, 10);
        unsigned nl = gpiod_chip_num_lines(chip);
        if (off >= nl)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: line %s: no such offset (%s has %u lines)",
                           what, c->line, gpiod_chip_name(chip), nl);
        line = gpiod_chip_get_line(chip, (unsigned)off);
        if (!line)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: line %s of %s: %s", what, c->line,
                           gpiod_chip_name(chip), strerror(errno));
    } else {
        errno = 0;
        line = gpiod_chip_find_line(chip, c->line);
        if (!line) {
            if (errno == 0 || errno == ENOENT)
                return ef_fail(m, EF_ERR_IO, "gpio: %s: line '%s' not found on %s", what, c->line,
                               gpiod_chip_name(chip));
            return ef_fail(m, EF_ERR_IO, "gpio: %s: looking for line '%s' on %s: %s", what, c->line,
                           gpiod_chip_name(chip), strerror(errno));
        }
    }
    L->line = line;
    L->offset = gpiod_line_offset(line);
    return EF_OK;
}

/* Argument checks of entry k; EF_ERR_ARG with a message. */
static int gpio_check_cfg(const ef_gpio_line_cfg_t *c, unsigned k, ef_msg_t *m)
{
    char wb[32];
    const char *what = gpio_what(c, k, wb, sizeof wb);
    if (!gpio_terminated(c->chip, sizeof c->chip) || !c->chip[0])
        return ef_fail(m, EF_ERR_ARG, "gpio: %s: no chip given", what);
    if (!gpio_terminated(c->line, sizeof c->line) || !c->line[0])
        return ef_fail(m, EF_ERR_ARG, "gpio: %s: no line given", what);
    if (c->dir > EF_GPIO_OUT)
        return ef_fail(m, EF_ERR_ARG, "gpio: %s: direction %u is neither input (0) nor output (1)",
                       what, (unsigned)c->dir);
    if (c->bias > EF_GPIO_BIAS_PULL_DOWN)
        return ef_fail(m, EF_ERR_ARG, "gpio: %s: bias %u out of range (0..%d)", what,
                       (unsigned)c->bias, (int)EF_GPIO_BIAS_PULL_DOWN);
    return EF_OK;
}

int ef_gpio_open(ef_gpio_t *g, const ef_gpio_line_cfg_t *cfg, unsigned n, ef_msg_t *m)
{
    if (!g || !cfg)
        return ef_fail(m, EF_ERR_ARG, "gpio: no set or no configuration given");
    if (gpio_registered(g))
        return ef_fail(m, EF_ERR_STATE, "gpio: the set is open already");
    memset(g, 0, sizeof *g);
    if (n == 0 || n > EF_GPIO_MAX_LINES)
        return ef_fail(m, EF_ERR_ARG, "gpio: %u lines: a set has 1 to %d", n, EF_GPIO_MAX_LINES);
    for (unsigned k = 0; k < n; k++) {
        int rc = gpio_check_cfg(&cfg[k], k, m);
        if (rc != EF_OK)
            return rc;
    }
    for (unsigned k = 0; k < n; k++) {
        g->l[k].cfg = cfg[k];
        g->l[k].cfg.active_low = (uint8_t)(cfg[k].active_low != 0);
        g->l[k].fd = -1;
    }
    g->n = n;

    int rc = EF_OK;
    for (unsigned k = 0; k < n && rc == EF_OK; k++)
        rc = gpio_resolve(g, k, m);
    /* The same line twice (chips are shared by name, so the same chip is the same pointer). */
    for (unsigned k = 1; k < n && rc == EF_OK; k++) {
        for (unsigned j = 0; j < k; j++) {
            if (g->l[j].chip == g->l[k].chip && g->l[j].offset == g->l[k].offset) {
                char a[32], b[32];
                rc = ef_fail(m, EF_ERR_ARG, "gpio: %s and %s both name %s:%u",
                             gpio_what(&g->l[j].cfg, j, a, sizeof a),
                             gpio_what(&g->l[k].cfg, k, b, sizeof b),
                             gpiod_chip_name((struct gpiod_chip *)g->l[k].chip),
                             (unsigned)g->l[k].offset);
                break;
            }
        }
    }
    for (unsigned k = 0; k < n && rc == EF_OK; k++)
        rc = gpio_request(g, k, m);
    if (rc == EF_OK && !gpio_register(g))
        rc = ef_fail(m, EF_ERR_FULL, "gpio: %d sets are open already (EF_GPIO_MAX_SETS)",
                     EF_GPIO_MAX_SETS);
    if (rc != EF_OK) {
        gpio_release(g);
        g->n = 0;
        return rc;
    }
    g->open = 1;
    return EF_OK;
}

int ef_gpio_process(ef_gpio_t *g, uint64_t now_ns, uint32_t *next_us, ef_msg_t *m)
{
    if (next_us)
        *next_us = UINT32_MAX;
    if (!g || !g->open)
        return ef_fail(m, EF_ERR_STATE, "gpio: process: the set is not open");
    int added = 0;
    uint64_t next = UINT64_MAX;
    /* One poll tells which inputs have events: a read per line only where there are some
     * (every system call counts under User-Mode Linux, and this runs every millisecond). */
    struct pollfd pf[EF_GPIO_MAX_LINES];
    unsigned np = 0;
    for (unsigned k = 0; k < g->n; k++)
        if (g->l[k].cfg.dir == EF_GPIO_IN)
            pf[np++] = (struct pollfd){g->l[k].fd, POLLIN, 0};
    if (np > 0 && poll(pf, np, 0) < 0 && errno != EINTR)
        return ef_fail(m, EF_ERR_IO, "gpio: poll: %s", strerror(errno));
    unsigned ip = 0;
    for (unsigned k = 0; k < g->n; k++) {
        ef_gpio_line_t *L = &g->l[k];
        if (L->cfg.dir != EF_GPIO_IN)
            continue;
        int ready = pf[ip++].revents != 0;
        int rc = ready ? gpio_drain(g, k, now_ns, &added, m) : EF_OK;
        if (rc != EF_OK)
            return rc;
        if (L->raw == L->value)
            continue;
        uint64_t db = (uint64_t)L->cfg.debounce_us * 1000u;
        /* Sampled: the level may have gone again unseen (merged events), so it has held
         * only as far as a sample saw it. */
        uint64_t upto = g->sampled ? L->t_seen_ns : now_ns;
        uint64_t held = upto > L->t_raw_ns ? upto - L->t_raw_ns : 0;
        if (held >= db)
            added += gpio_commit(g, k);
        else if (db - held < next)
            next = db - held;
    }
    if (next_us && next != UINT64_MAX) {
        uint64_t us = (next + 999u) / 1000u;
        *next_us = us >= UINT32_MAX ? UINT32_MAX - 1 : (uint32_t)us;
    }
    return added;
}

int ef_gpio_sample(ef_gpio_t *g, uint64_t now_ns, ef_msg_t *m)
{
    if (!g || !g->open)
        return ef_fail(m, EF_ERR_STATE, "gpio: sample: the set is not open");
    g->sampled = 1;
    int added = 0;
    char nm[160];
    for (unsigned k = 0; k < g->n; k++) {
        ef_gpio_line_t *L = &g->l[k];
        if (L->cfg.dir != EF_GPIO_IN)
            continue;
        int v = gpiod_line_get_value((struct gpiod_line *)L->line);
        if (v < 0)
            return ef_fail(m, EF_ERR_IO, "gpio: %s: reading the level: %s",
                           ef_gpio_name(g, k, nm, sizeof nm), strerror(errno));
        uint64_t db = (uint64_t)L->cfg.debounce_us * 1000u;
        if ((uint8_t)v != L->raw) {
            /* A change between two samples: the level before held as far as the last sample
             * that saw it (not until now), the new one starts now. */
            if (L->raw != L->value && L->t_seen_ns >= L->t_raw_ns &&
                L->t_seen_ns - L->t_raw_ns >= db)
                added += gpio_commit(g, k);
            else if (L->raw != L->value)
                L->rejected++;
            L->raw = (uint8_t)v;
            L->t_raw_ns = now_ns > L->t_raw_ns ? now_ns : L->t_raw_ns;
            L->edges++;
            if (db == 0)
                added += gpio_commit(g, k);
        }
        L->t_seen_ns = now_ns;
        if (L->raw != L->value && now_ns >= L->t_raw_ns && now_ns - L->t_raw_ns >= db)
            added += gpio_commit(g, k);
    }
    return added;
}

int ef_gpio_wait(ef_gpio_t *g, uint32_t timeout_us)
{
    if (!g || !g->open)
        return EF_ERR_STATE;
    struct pollfd p[EF_GPIO_MAX_LINES];
    nfds_t np = 0;
    for (unsigned k = 0; k < g->n; k++) {
        if (g->l[k].cfg.dir == EF_GPIO_IN && g->l[k].fd >= 0) {
            p[np].fd = g->l[k].fd;
            p[np].events = POLLIN | POLLPRI;
            p[np].revents = 0;
            np++;
        }
    }
    struct timespec ts = {(time_t)(timeout_us / 1000000u), (long)(timeout_us % 1000000u) * 1000};
    int r = ppoll(np ? p : NULL, np, &ts, NULL);
    if (r < 0)
        return errno == EINTR ? 0 : EF_ERR_IO;
    return r > 0;
}

int ef_gpio_next_event(ef_gpio_t *g, ef_gpio_event_t *ev)
{
    if (!g || g->ev_count == 0)
        return 0;
    if (ev)
        *ev = g->evq[g->ev_head];
    g->ev_head = (g->ev_head + 1) % EF_GPIO_EVQ;
    g->ev_count--;
    return 1;
}

int ef_gpio_get(const ef_gpio_t *g, unsigned k, uint8_t *value)
{
    if (!g || !g->open || k >= g->n || !value)
        return EF_ERR_ARG;
    *value = g->l[k].value;
    return EF_OK;
}

int ef_gpio_set(ef_gpio_t *g, unsigned k, uint8_t value, ef_msg_t *m)
{
    char nm[160];
    if (!g || !g->open)
        return ef_fail(m, EF_ERR_ARG, "gpio: set: the set is not open");
    if (k >= g->n)
        return ef_fail(m, EF_ERR_ARG, "gpio: set: line %u of a set of %u", k, g->n);
    if (g->l[k].cfg.dir != EF_GPIO_OUT)
        return ef_fail(m, EF_ERR_ARG, "gpio: set: %s is an input",
                       ef_gpio_name(g, k, nm, sizeof nm));
    uint8_t v = (uint8_t)(value != 0);
    if (gpiod_line_set_value((struct gpiod_line *)g->l[k].line, v) < 0)
        return ef_fail(m, EF_ERR_IO, "gpio: %s: setting %u refused by the kernel: %s",
                       ef_gpio_name(g, k, nm, sizeof nm), (unsigned)v, strerror(errno));
    g->l[k].value = v;
    return EF_OK;
}

int ef_gpio_safe(ef_gpio_t *g, ef_msg_t *m)
{
    int rc = EF_OK;
    if (!g || !g->open)
        return EF_OK;
    for (unsigned k = 0; k < g->n; k++) {
        if (g->l[k].cfg.dir != EF_GPIO_OUT)
            continue;
        int r = ef_gpio_set(g, k, g->l[k].cfg.safe, rc == EF_OK ? m : NULL);
        if (r != EF_OK && rc == EF_OK)
            rc = r;
    }
    return rc;
}

int ef_gpio_spec(ef_gpio_line_cfg_t *l, const char *spec, const char *chip)
{
    const char *colon = strchr(spec, ':');
    if (colon) {
        size_t n = (size_t)(colon - spec);
        if (n == 0 || n >= sizeof l->chip || !colon[1] || strlen(colon + 1) >= sizeof l->line)
            return EF_GPIO_SPEC_PARTS;
        memcpy(l->chip, spec, n);
        l->chip[n] = 0;
        snprintf(l->line, sizeof l->line, "%s", colon + 1);
        return EF_GPIO_SPEC_OK;
    }
    if (!chip || !chip[0])
        return EF_GPIO_SPEC_NOCHIP;
    if (!spec[0] || strlen(spec) >= sizeof l->line || strlen(chip) >= sizeof l->chip)
        return EF_GPIO_SPEC_LONG;
    snprintf(l->chip, sizeof l->chip, "%s", chip);
    snprintf(l->line, sizeof l->line, "%s", spec);
    return EF_GPIO_SPEC_OK;
}

int ef_gpio_find(const ef_gpio_t *g, const char *what)
{
    if (!g || !what)
        return -1;
    for (unsigned k = 0; k < g->n; k++)
        if (g->l[k].cfg.what && strcmp(g->l[k].cfg.what, what) == 0)
            return (int)k;
    return -1;
}

const char *ef_gpio_name(const ef_gpio_t *g, unsigned k, char *buf, unsigned n)
{
    if (!buf || n == 0)
        return "";
    if (!g || k >= g->n) {
        snprintf(buf, n, "line %u", k);
        return buf;
    }
    const ef_gpio_line_t *L = &g->l[k];
    char wb[32];
    const char *what = gpio_what(&L->cfg, k, wb, sizeof wb);
    if (L->chip && L->line)
        snprintf(buf, n, "%s (%s:%u)", what, gpiod_chip_name((struct gpiod_chip *)L->chip),
                 (unsigned)L->offset);
    else
        snprintf(buf, n, "%s (%s:%s)", what, L->cfg.chip, L->cfg.line);
    return buf;
}

void ef_gpio_close(ef_gpio_t *g)
{
    if (!g || !g->open)
        return;
    gpio_unregister(g);
    (void)ef_gpio_safe(g, NULL);
    g->open = 0;
    gpio_release(g);
}

void ef_gpio_safe_all(void)
{
    int e = errno; /* a signal handler leaves errno as it found it */
    for (unsigned i = 0; i < EF_GPIO_MAX_SETS; i++) {
        ef_gpio_t *g = atomic_load(&gpio_sets[i]);
        if (!g || !g->open)
            continue;
        for (unsigned k = 0; k < g->n; k++) {
            ef_gpio_line_t *L = &g->l[k];
            if (L->cfg.dir == EF_GPIO_OUT && L->line &&
                gpiod_line_set_value((struct gpiod_line *)L->line, L->cfg.safe) == 0)
                L->value = L->cfg.safe;
        }
    }
    errno = e;
}
