/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_mio.h
 * @brief Machine I/O: what a controller wires to GPIO (docs/io.md). The e-stop input, drive
 * enable outputs, drive alarm inputs, feed hold and cycle start inputs, a charge-pump
 * output and the program's digital outputs (M62-M65), on ef_gpio.h lines, configured by a
 * machine file. The streamers (ef_can_stream(), ef_mb_stream()) call it; it never talks to
 * a drive itself: it says what happened, the streamer stops the drives.
 *
 * ## States (ef_mio_state())
 *
 *     from       event                                              to
 *     (closed)   ef_mio_open(): outputs safe, inputs read           SAFE
 *     SAFE       ef_mio_arm(): e-stop clear, no latch, no alarm     ARMED (enable on, pump on)
 *     SAFE       ef_mio_arm() otherwise                             SAFE (EF_ERR_ESTOP)
 *     ARMED      e-stop active, alarm active, GPIO error            TRIPPED (latch written)
 *     ARMED      ef_mio_disarm() (the stream ended)                 SAFE (enable off, pump off)
 *     TRIPPED    ef_mio_disarm() (the drives are at rest, or the    SAFE
 *                streamer's bound ran out)
 *
 * TRIPPED keeps enable on and the pump running: the drives must be able to carry out the
 * controlled stop the streamer commands; ef_mio_disarm() drops them once the drives report
 * rest or the streamer's stop bound has passed. Outputs are safe (enable off, pump still)
 * in SAFE and after ef_mio_close(), and on every exit path the process has (ef_gpio.h).
 *
 * ## The e-stop latch
 * A trip writes the latch file (cfg.latch): a later ef_mio_arm() (the next stream) refuses
 * while it exists, even with the input released. `evenfeed io reset` removes it, and only
 * while the e-stop input reads released: leaving e-stop takes the release and an explicit
 * reset, never the release alone.
 *
 * ## Feed hold and cycle start
 * ef_mio_hold() says whether motion must be held: set by the feed-hold input becoming
 * active; cleared by a cycle-start edge while the feed-hold input is released (with no
 * cycle-start input configured: by the release of feed hold itself).
 *
 * ## The I/O thread
 * One thread of its own, every ::EF_MIO_TICK_US (or the pump's half period if shorter):
 * it reads the inputs' edge events and samples their levels (both: the v1 uAPI reports the
 * level its interrupt thread reads, so an edge pair faster than that thread merges into one
 * event that says nothing; the samples still see a press that lasts a few ticks), debounces
 * them (ef_gpio.h), trips on e-stop and alarms, follows feed hold, and makes the charge
 * pump's square wave. The streamer's loop only reads what the thread found
 * (ef_mio_process()), so a slow loop delays the stop command, never the detection.
 *
 * ## The charge pump
 * A square wave of cfg.pump_hz on its own line while ARMED or TRIPPED. It toggles only while
 * the streamer's loop calls ef_mio_process() at least every cfg.pump_watchdog_ms: a
 * streamer that hangs stops the wave as a killed one does (the thread dies with the
 * process), which drives' safety relays read as "controller gone".
 *
 * ## Synchronized outputs (M62-M65)
 * Output P of the program is line cfg.out[P]; ef_mio_out() drives it; the streamer decides
 * when (M64/M65 at once, M62/M63 at the commanded point of the path).
 *
 * Context: one thread (the streamer's bus thread) calls everything but the pump thread's
 * own work. Storage: fixed arrays (::EF_MIO_MAX_AXES, ::EF_MIO_MAX_OUTS) and one thread.
 */
#ifndef EF_MIO_H
#define EF_MIO_H

#include <pthread.h>
#include <stdint.h>

#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/io/ef_gpio.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most drive enable outputs and alarm inputs (one per axis, or one shared). */
#ifndef EF_MIO_MAX_AXES
#define EF_MIO_MAX_AXES 3
#endif
/** The I/O thread's period (us): input sampling and debounce resolution. */
#ifndef EF_MIO_TICK_US
#define EF_MIO_TICK_US 1000u
#endif
/** How often the I/O thread samples the inputs' levels (us; events are read every tick). */
#ifndef EF_MIO_SAMPLE_US
#define EF_MIO_SAMPLE_US 2000u
#endif
/** SCHED_FIFO priority of the I/O thread, where the process may set it. */
#ifndef EF_MIO_RT_PRIO
#define EF_MIO_RT_PRIO 40
#endif
/** Most program outputs (M62-M65 P0..P(n-1)). */
#ifndef EF_MIO_MAX_OUTS
#define EF_MIO_MAX_OUTS 8
#endif

/** States (file comment). */
typedef enum {
    EF_MIO_CLOSED = 0,
    EF_MIO_SAFE = 1,
    EF_MIO_ARMED = 2,
    EF_MIO_TRIPPED = 3,
} ef_mio_state_t;

/** What tripped the machine I/O. */
typedef enum {
    EF_MIO_TRIP_NONE = 0,
    EF_MIO_TRIP_ESTOP = 1, /**< the e-stop input went active */
    EF_MIO_TRIP_ALARM = 2, /**< a drive alarm input went active */
    EF_MIO_TRIP_GPIO = 3,  /**< reading an input failed: taken as e-stop */
} ef_mio_trip_t;

/** The machine file, parsed (ef_mio_cfg_load()). Indexes are into lines[]; -1: not wired. */
typedef struct {
    ef_gpio_line_cfg_t lines[EF_GPIO_MAX_LINES]; /**< every line but the pump's */
    unsigned n;
    ef_gpio_line_cfg_t pump_line; /**< the charge pump's line (own set: its own thread) */
    int estop, hold, start, pump;
    int enable[EF_MIO_MAX_AXES], alarm[EF_MIO_MAX_AXES], out[EF_MIO_MAX_OUTS];
    unsigned n_enable, n_alarm;
    uint32_t pump_hz;          /**< charge pump frequency (default 500) */
    uint32_t pump_watchdog_ms; /**< the loop must call ef_mio_process() this often (250) */
    uint32_t stop_ms;          /**< longest wait for rest before enable drops (default 2000) */
    char latch[256];           /**< the e-stop latch file */
    char path[256];            /**< the machine file */
    char names[EF_GPIO_MAX_LINES][32]; /**< storage of lines[k].what ("enable.1") */
} ef_mio_cfg_t;

/**
 * @brief Read a machine file (INI, docs/io.md). Unknown sections or keys, a bad value, a
 * line named twice (same chip and line text), a function wired twice: refused, nothing
 * applied.
 * @retval EF_OK
 * @retval EF_ERR_IO the file cannot be read
 * @retval EF_ERR_ARG a bad line (message: "file:line: ..."), or no e-stop input in a file
 *         that wires an enable output (an enable nothing can drop is refused)
 */
int ef_mio_cfg_load(ef_mio_cfg_t *c, const char *path, ef_msg_t *m);

/** The running machine I/O. */
typedef struct ef_mio_s {
    ef_mio_cfg_t cfg;
    ef_gpio_t in;                     /**< the inputs: the I/O thread's */
    ef_gpio_t out;                    /**< enable and program outputs: the caller's thread */
    ef_gpio_t pump_g;                 /**< the pump's line: the I/O thread's */
    int8_t set_of[EF_GPIO_MAX_LINES]; /**< cfg.lines[k]'s index in `in` or `out` */
    /* Shared with the I/O thread (under mu). */
    pthread_t th;
    pthread_mutex_t mu;
    int th_started, th_quit;
    int state;        /**< ::ef_mio_state_t */
    int trip;         /**< ::ef_mio_trip_t */
    int trip_line;    /**< the input that tripped (index in cfg.lines), -1 */
    int trip_told;    /**< ef_mio_process() has returned the trip */
    uint64_t trip_ns; /**< CLOCK_MONOTONIC time of its edge */
    char trip_text[200];
    int hold;     /**< feed hold in force */
    int gpio_err; /**< the thread could not read the inputs */
    char gpio_text[200];
    uint64_t alive_ns; /**< last ef_mio_process() */
    uint64_t pump_edges;
    uint64_t ticks, late_ticks; /**< I/O thread rounds, and those a tick or more late */
    int rt;                     /**< the I/O thread runs SCHED_FIFO (EF_MIO_RT_PRIO) */
    uint64_t last_sample_ns;
} ef_mio_t;

/**
 * @brief Request the lines (outputs safe: enable off), read the inputs. State SAFE.
 * @retval EF_OK
 * @retval EF_ERR_ARG c NULL or inconsistent
 * @retval EF_ERR_IO ef_gpio_open()'s errors (message names chip, line, consumer), or the
 *         pump thread could not start
 */
int ef_mio_open(ef_mio_t *io, const ef_mio_cfg_t *c, ef_msg_t *m);

/**
 * @brief Before motion: refuse while the e-stop input is active, the latch exists or an
 * alarm input is active; otherwise enable on, pump on: ARMED.
 * @retval EF_OK ARMED
 * @retval EF_ERR_ESTOP refused (message names the input, or the latch and how to reset it)
 * @retval EF_ERR_IO a line could not be read or driven (nothing enabled)
 * @retval EF_ERR_STATE not SAFE
 */
int ef_mio_arm(ef_mio_t *io, ef_msg_t *m);

/**
 * @brief Read the inputs (call at least every cfg.pump_watchdog_ms while ARMED: it also
 * feeds the pump's watchdog). On the first trip: TRIPPED, latch written.
 * @param next_us set to the time until a debounce ends (UINT32_MAX: none)
 * @retval EF_OK nothing new, or no trip
 * @retval EF_ERR_ESTOP tripped now (returned once; message names the input and says what
 *         it was)
 */
int ef_mio_process(ef_mio_t *io, uint32_t *next_us, ef_msg_t *m);

/** @brief 1 while feed hold is in force (file comment), else 0. */
int ef_mio_hold(const ef_mio_t *io);

/**
 * @brief Drive program output p (M62-M65 P word) to value.
 * @retval EF_OK
 * @retval EF_ERR_ARG p has no line in the machine file (message says which P)
 * @retval EF_ERR_IO the kernel refused
 */
int ef_mio_out(ef_mio_t *io, unsigned p, int value, ef_msg_t *m);

/**
 * @brief The M62-M65 words of an event's text ("M8 M64 P1"), in order: codes[k] 62..65 and
 * ps[k] its P (-1: none given). At most max of them.
 * @return how many (0: none)
 */
int ef_mio_m_words(const char *text, int *codes, long *ps, int max);

/**
 * @brief Enable off, pump stopped, program outputs safe: SAFE (from ARMED or TRIPPED).
 * The pump stops whatever else happens (its thread stops the wave), so a safety relay on it
 * drops the drives' enable even where a line cannot be written.
 * @retval EF_OK every enable and program output was written inactive (or nothing to do)
 * @retval EF_ERR_IO a line could not be written (its chip gone, the kernel refused): m names
 *         it; the caller must not say enable dropped
 */
int ef_mio_disarm(ef_mio_t *io, ef_msg_t *m);

/** @brief Safe outputs, lines released, the pump thread ended. */
void ef_mio_close(ef_mio_t *io);

/** @brief ::ef_mio_state_t. */
int ef_mio_state(const ef_mio_t *io);

/**
 * @brief `evenfeed io reset`: remove the e-stop latch, only while the e-stop input reads
 * released (the lines are requested for the check and released again).
 * @retval EF_OK no latch any more (there may have been none)
 * @retval EF_ERR_ESTOP the e-stop input is active: the latch stays
 * @retval EF_ERR_IO the lines or the latch file could not be used
 */
int ef_mio_reset(const ef_mio_cfg_t *c, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_MIO_H */
