/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gpio.h
 * @brief A set of GPIO lines on Linux's GPIO character device through libgpiod 1.6 (Debian
 * 12's API and the kernel's v1 uAPI): inputs with software debounce and edge events,
 * outputs with a safe state. The machine I/O (ef_mio.h) is built on it.
 *
 * Lines are named by chip and line: the chip as gpiod_chip_open_lookup() takes it (a name
 * "gpiochip0", a path "/dev/gpiochip0", a number "0" or a label "gpio-sim.0-node0"), the line
 * by its name (gpiod_chip_find_line) or, when all digits, its offset. Every line is requested
 * with the consumer label "evenfeed" (what `gpioinfo` shows), active-low and bias as
 * configured (bias needs kernel 5.5).
 *
 * ## Values
 * All values here are logical: 1 = active. With active_low the kernel inverts both ways.
 *
 * ## Inputs: edges and debounce
 * Every input is requested for both edges. libgpiod 1.6 has no kernel debounce (the v1
 * uAPI offers none), so it is done here: the raw level follows the kernel's edge events
 * (timestamps on CLOCK_MONOTONIC), and the debounced value takes a new raw level once that
 * level has held for debounce_us without an edge. A pulse shorter than debounce_us is
 * ignored; a change that holds is reported with the time of its first edge, so its latency
 * is measured from the edge, not from the end of the debounce. debounce_us = 0: every edge
 * counts at once. At open the debounced value is the level read then (no debounce).
 * With each edge the kernel reports the level it reads after it, so the same level twice
 * means the line left it and came back in between (a pulse whose edges merged): with a
 * debounce that is a rejected level; with debounce_us = 0 it is reported as two changes (away
 * and back) at the second edge's time, so no pulse goes unreported. When the kernel's event
 * queue may have overflowed (16 events at once, edges lost), the level is read back directly
 * and a difference counts as an edge at now_ns.
 *
 * ## Outputs: the safe state
 * Each output has a safe logical value (cfg.safe), driven at request time, by
 * ef_gpio_safe(), by ef_gpio_close() and by ef_gpio_safe_all() (the signal handlers' call).
 * The kernel keeps a released line's last level on most chips: a process killed with
 * SIGKILL leaves its outputs as they were, which is why a drive's enable must also depend on
 * a charge pump (ef_mio.h).
 *
 * ## Time, context
 * Non-blocking: ef_gpio_process(g, now_ns, &next_us) reads what the kernel queued and ends
 * debounce intervals; ef_gpio_wait() sleeps on the lines' descriptors for at most a bound.
 * One thread uses a set; ef_gpio_safe_all() is the exception (async-signal-safe: ioctls on
 * descriptors already open, no allocation, no locks).
 *
 * ## Storage
 * An ef_gpio_t holds its lines in arrays of ::EF_GPIO_MAX_LINES; the pending debounced
 * changes in a ring of ::EF_GPIO_EVQ (a full ring drops the oldest: the current value is
 * always ef_gpio_get()'s). libgpiod allocates the chips' and lines' own objects.
 */
#ifndef EF_GPIO_H
#define EF_GPIO_H

#include <stdint.h>

#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most lines in one set (all chips together). */
#ifndef EF_GPIO_MAX_LINES
#define EF_GPIO_MAX_LINES 32
#endif
/** Debounced changes kept between two ef_gpio_next_event() calls. */
#ifndef EF_GPIO_EVQ
#define EF_GPIO_EVQ 64
#endif
/** Most open sets at once (for ef_gpio_safe_all()). */
#ifndef EF_GPIO_MAX_SETS
#define EF_GPIO_MAX_SETS 4
#endif
/** Consumer label of every requested line. */
#define EF_GPIO_CONSUMER "evenfeed"

/** Direction of a line. */
typedef enum {
    EF_GPIO_IN = 0,
    EF_GPIO_OUT = 1,
} ef_gpio_dir_t;

/** Bias of a line (inputs mostly; kernel 5.5+). */
typedef enum {
    EF_GPIO_BIAS_AS_IS = 0, /**< leave the line's bias as it is */
    EF_GPIO_BIAS_DISABLE,   /**< no pull */
    EF_GPIO_BIAS_PULL_UP,
    EF_GPIO_BIAS_PULL_DOWN,
} ef_gpio_bias_t;

/** One line of a set. */
typedef struct {
    const char *what;     /**< its function, for messages ("estop"); NULL: "line k" */
    char chip[64];        /**< chip: name, path, number or label (see the file comment) */
    char line[64];        /**< line name, or its offset in decimal */
    uint8_t dir;          /**< ::ef_gpio_dir_t */
    uint8_t active_low;   /**< 1: low is active (1) */
    uint8_t bias;         /**< ::ef_gpio_bias_t */
    uint8_t safe;         /**< outputs: the logical value of the safe state */
    uint32_t debounce_us; /**< inputs: a level must hold this long (0: none) */
} ef_gpio_line_cfg_t;

/** A debounced change of an input. */
typedef struct {
    uint8_t line;  /**< index in the set */
    uint8_t value; /**< the new logical value */
    uint64_t t_ns; /**< CLOCK_MONOTONIC time of the edge that began the new level */
} ef_gpio_event_t;

/** Per-line state (read-only for callers). */
typedef struct {
    ef_gpio_line_cfg_t cfg;
    void *chip;         /**< struct gpiod_chip * (shared by lines of one chip) */
    void *line;         /**< struct gpiod_line * */
    int fd;             /**< inputs: the event descriptor; -1 otherwise */
    uint32_t offset;    /**< offset on its chip */
    uint8_t raw;        /**< inputs: last level seen (logical) */
    uint8_t value;      /**< inputs: debounced value; outputs: value driven */
    uint64_t t_raw_ns;  /**< inputs: time of the edge that began the raw level */
    uint64_t t_seen_ns; /**< inputs, sampled sets: last time the raw level was seen (a
                             level only counts as held up to there) */
    uint64_t edges;     /**< inputs: edges seen (the kernel's events) */
    uint64_t rejected;  /**< inputs: raw levels that did not last debounce_us */
} ef_gpio_line_t;

/** A set of lines. */
typedef struct {
    ef_gpio_line_t l[EF_GPIO_MAX_LINES];
    unsigned n;
    ef_gpio_event_t evq[EF_GPIO_EVQ];
    unsigned ev_head, ev_count;
    uint64_t ev_lost; /**< debounced changes dropped from a full ring */
    int open;
    int sampled; /**< ef_gpio_sample() is in use: the levels come from it too */
} ef_gpio_t;

/**
 * @brief Request every line of cfg (n of them) for this process, drive the outputs to
 * their safe values, read the inputs' levels. All or nothing: on an error nothing stays
 * requested and g is left closed (zeroed but for the copied configuration; EF_ERR_STATE:
 * untouched). g need not be initialized.
 * @retval EF_OK
 * @retval EF_ERR_ARG n is 0 or above ::EF_GPIO_MAX_LINES, a chip or line field empty, a
 *         direction or bias out of range, the same line (chip and offset) named twice
 *         (message names both entries)
 * @retval EF_ERR_IO no such chip, no such line on it, the line held by another consumer
 *         (message names the consumer), the kernel refused the request (e.g. an output on
 *         an input-only line, a bias the chip cannot do), a level could not be read
 * @retval EF_ERR_STATE g is open already
 * @retval EF_ERR_FULL ::EF_GPIO_MAX_SETS sets are open already (ef_gpio_safe_all()'s registry)
 */
int ef_gpio_open(ef_gpio_t *g, const ef_gpio_line_cfg_t *cfg, unsigned n, ef_msg_t *m);

/**
 * @brief Read the edges the kernel queued and end the debounce intervals that have run
 * out by now_ns (CLOCK_MONOTONIC); new debounced changes go to the ring.
 * @param next_us set (if not NULL) to the time until the next debounce interval ends, or
 *        UINT32_MAX when none is running.
 * @return the number of debounced changes added (>= 0)
 * @retval EF_ERR_STATE the set is not open
 * @retval EF_ERR_IO reading an event or a level failed (message names the line): the caller
 *         must treat every input as unknown (the machine I/O takes it as e-stop)
 */
int ef_gpio_process(ef_gpio_t *g, uint64_t now_ns, uint32_t *next_us, ef_msg_t *m);

/**
 * @brief Read every input's level now and take it as the raw level (an edge at now_ns
 * where it differs), then end the debounce intervals that have run out. For callers that
 * sample at a fixed period: the v1 uAPI decides an event's edge by the level its interrupt
 * thread reads, so two edges closer together than that thread's latency (under User-Mode
 * Linux a tick, 10 ms) merge into one event with the level as it was before. Once a set is
 * sampled, such an event (one that reports the raw level) changes nothing; the samples
 * see a level that lasts a period or more.
 * @return the number of debounced changes added (>= 0)
 * @retval EF_ERR_STATE the set is not open
 * @retval EF_ERR_IO a level could not be read (message names the line)
 */
int ef_gpio_sample(ef_gpio_t *g, uint64_t now_ns, ef_msg_t *m);

/**
 * @brief Sleep until an input's descriptor is readable or timeout_us passes (0: just look).
 * Does not read the events: ef_gpio_process() does.
 * @return 1 if an input has events, 0 on time-out (or when a signal interrupted the sleep)
 * @retval EF_ERR_STATE the set is not open
 * @retval EF_ERR_IO poll failed
 */
int ef_gpio_wait(ef_gpio_t *g, uint32_t timeout_us);

/**
 * @brief Take the oldest debounced change.
 * @return 1 if ev was filled, 0 if the ring is empty
 */
int ef_gpio_next_event(ef_gpio_t *g, ef_gpio_event_t *ev);

/**
 * @brief The debounced logical value of input k, or the value driven on output k.
 * @retval EF_OK
 * @retval EF_ERR_ARG k out of range, or the set not open
 */
int ef_gpio_get(const ef_gpio_t *g, unsigned k, uint8_t *value);

/**
 * @brief Drive output k to a logical value.
 * @retval EF_OK
 * @retval EF_ERR_ARG k out of range, not an output, or the set not open
 * @retval EF_ERR_IO the kernel refused (message names the line)
 */
int ef_gpio_set(ef_gpio_t *g, unsigned k, uint8_t value, ef_msg_t *m);

/**
 * @brief Drive every output of the set to its safe value (all are tried).
 * @retval EF_OK also for a set that is not open (nothing to drive)
 * @retval EF_ERR_IO at least one could not be set (message names the first)
 */
int ef_gpio_safe(ef_gpio_t *g, ef_msg_t *m);

/** Why ef_gpio_spec() refused a line spec. */
typedef enum {
    EF_GPIO_SPEC_OK = 0,
    EF_GPIO_SPEC_PARTS = 1,  /**< CHIP:LINE with an empty or too long part */
    EF_GPIO_SPEC_NOCHIP = 2, /**< LINE alone and no default chip */
    EF_GPIO_SPEC_LONG = 3,   /**< LINE alone, too long */
} ef_gpio_spec_t;

/**
 * @brief Fill l->chip and l->line from "CHIP:LINE" (split at the first ':'), or from "LINE"
 * on `chip` (NULL or "": none). Nothing else of l is touched.
 * @return ::ef_gpio_spec_t (0: done)
 */
int ef_gpio_spec(ef_gpio_line_cfg_t *l, const char *spec, const char *chip);

/** @brief Index of the line whose cfg.what is `what`, or -1. */
int ef_gpio_find(const ef_gpio_t *g, const char *what);

/** @brief A short text naming line k: "estop (gpiochip0:3)". */
const char *ef_gpio_name(const ef_gpio_t *g, unsigned k, char *buf, unsigned n);

/**
 * @brief Drive the outputs to their safe values and release every line and chip; the set
 * leaves ef_gpio_safe_all()'s registry first. Safe to call on a set that is not open: zeroed,
 * closed already, or whose open failed (does nothing).
 */
void ef_gpio_close(ef_gpio_t *g);

/**
 * @brief Every open set's outputs to their safe values: for signal handlers and atexit.
 * Async-signal-safe (ioctls only).
 */
void ef_gpio_safe_all(void);

#ifdef __cplusplus
}
#endif

#endif /* EF_GPIO_H */
