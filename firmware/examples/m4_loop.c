/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Integration example (firmware/examples/README.md): the interpolator in a 1 kHz SysTick
 * interrupt, the smoother in the background loop, moves handed over through a
 * single-producer single-consumer ring. Runs the sample programs the golden test generates
 * (tests/m4/golden.h) one after the other under QEMU, checks the setpoint stream and
 * prints the worst costs.
 *
 * Ownership: the interrupt owns ex_ip and the ring's tail, the background owns ex_sm and
 * the ring's head. Neither writes what the other owns, except between programs, when
 * SysTick is stopped.
 */
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include "ef_m4.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/core/ef_math.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "golden.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define EX_PERIOD_US 1000u
/* SysTick counts the processor clock, 25 MHz on QEMU's mps2-an386 (checked at start
 * against timer 0): 25 000 ticks a millisecond. */
#define EX_SYSTICK_HZ     25000000u
#define EX_SYSTICK_RELOAD (EX_SYSTICK_HZ / 1000u - 1u)
/* Power of two, so the free-running indices wrap consistently. 32 moves cover the longest
 * ef_smooth_push() (~230 000 instructions, 2 ms at shift 3) many times over. */
#define EX_RING 32u
/* Moves handed to the interpolator per period at most: ef_interp_push() prepares a move's
 * power basis (a few hundred instructions), so taking every waiting move in one interrupt
 * made its worst case eight pushes long (17 790 instructions measured). Two keep the queue
 * ahead of moves down to half a period long; shorter ones on average would underrun, which
 * the image counts and fails on. */
#define EX_PUSH_PER_PERIOD 2u
/* Instructions per tick of timer 0 (25 MHz) at 2^EF_M4_ICOUNT_SHIFT ns per instruction,
 * at least 1: the counter's resolution. */
#define EX_RES ((40u >> EF_M4_ICOUNT_SHIFT) > 0u ? (40u >> EF_M4_ICOUNT_SHIFT) : 1u)

#define EX_SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define EX_SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define EX_SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define EX_SHPR3    (*(volatile uint32_t *)0xE000ED20u)
/* CSR: enable, interrupt, processor clock (1 would be the 1 MHz reference clock). */
#define EX_SYST_ON      0x7u
#define EX_TIMER0_VALUE (*(volatile uint32_t *)0x40000004u)

/* ---------------------------------------------------------------- shared with the ISR */

static ef_move_t ex_ring[EX_RING];
static _Atomic uint32_t ex_head; /* written by the background only */
static _Atomic uint32_t ex_tail; /* written by the interrupt only */
/* Set by the background once the ring is full or the program is all in it: the interrupt
 * starts taking moves only then, so the smoother has a head start of EX_RING moves. */
static _Atomic uint32_t ex_go;
static _Atomic uint32_t ex_fed; /* the whole program is in the ring */
static _Atomic uint32_t ex_end; /* set by the interrupt: fed, all run, at rest */

static ef_interp_t ex_ip;

/* Written by the interrupt, read by the background after ex_end (acquire) or with
 * SysTick stopped. */
typedef struct {
    uint32_t periods;   /* interrupts since go */
    uint32_t setpoints; /* of those, with a valid setpoint */
    uint32_t moving;    /* of those, while moving */
    uint32_t underruns; /* EF_ERR_UNDERRUN */
    uint32_t errors;    /* any other error of push or process */
    uint32_t jumps;     /* steps longer than the fastest feed allows */
    uint32_t isr_worst; /* instructions, handoff plus ef_interp_process */
    float step_max;     /* longest step between two setpoints */
    ef_setpoint_t last; /* last setpoint */
    uint32_t probe[3];  /* timer 0 at the first interrupts (clock check) */
    uint32_t nprobe;
} ex_isr_t;
static ex_isr_t ex_isr;
/* All interrupts' counted instructions, for taking them out of the background's costs. */
static _Atomic uint32_t ex_isr_total;
static float ex_step_lim; /* set with SysTick stopped */

void SysTick_Handler(void);

void SysTick_Handler(void)
{
    if (ex_isr.nprobe < 3u) {
        ex_isr.probe[ex_isr.nprobe++] = EX_TIMER0_VALUE;
    }
    if (!atomic_load_explicit(&ex_go, memory_order_acquire)) {
        return;
    }
    uint32_t t0 = ef_m4_icount_begin();
    /* Consumer side: top the interpolator's queue up from the ring. */
    uint32_t tail = atomic_load_explicit(&ex_tail, memory_order_relaxed);
    uint32_t head = atomic_load_explicit(&ex_head, memory_order_acquire);
    int err = 0;
    for (uint32_t k = 0; k < EX_PUSH_PER_PERIOD && tail != head && ef_interp_space(&ex_ip) > 0u;
         k++) {
        err |= ef_interp_push(&ex_ip, &ex_ring[tail % EX_RING]) != EF_OK;
        tail++;
    }
    /* Release: the slots are read before the producer may overwrite them. */
    atomic_store_explicit(&ex_tail, tail, memory_order_release);
    ef_setpoint_t sp;
    int rc = ef_interp_process(&ex_ip, EX_PERIOD_US, NULL, &sp);
    uint32_t n = ef_m4_icount_end(t0);

    ex_isr_t *s = &ex_isr;
    atomic_store_explicit(&ex_isr_total,
                          atomic_load_explicit(&ex_isr_total, memory_order_relaxed) + n,
                          memory_order_relaxed);
    if (n > s->isr_worst) {
        s->isr_worst = n;
    }
    s->periods++;
    s->errors += (uint32_t)err;
    if (rc == EF_ERR_UNDERRUN) {
        s->underruns++;
    } else if (rc != EF_OK) {
        s->errors++;
    } else {
        float step = ef_v3_norm(ef_v3_sub(sp.p, s->last.p));
        if (step > s->step_max) {
            s->step_max = step;
        }
        s->jumps += step > ex_step_lim;
        s->setpoints++;
        s->moving += sp.moving;
        s->last = sp;
        /* fed before head: a head read first could be older than the last publish */
        if (!sp.moving && ef_interp_space(&ex_ip) == EF_INTERP_QUEUE &&
            atomic_load_explicit(&ex_fed, memory_order_acquire) &&
            tail == atomic_load_explicit(&ex_head, memory_order_acquire)) {
            atomic_store_explicit(&ex_end, 1u, memory_order_release);
        }
    }
}

/* ---------------------------------------------------------------- background */

static ef_smooth_t ex_sm;
static uint32_t ex_push_worst, ex_pull_worst, ex_fin_worst, ex_work_worst, ex_isr_worst, ex_failed,
    ex_checks, ex_units_all;
static uint32_t ex_push_prog, ex_pull_prog, ex_fin_prog, ex_work_prog; /* the running program's */
static uint32_t ex_units; /* work units done in idle time, the running program's */

/* Instructions since t0 of the background alone: the interrupts' counted instructions in
 * between are taken out (their entry and exit, a few dozen instructions each, are not). */
static uint32_t ex_cost(uint32_t t0, uint32_t isr0)
{
    uint32_t n = ef_m4_icount_end(t0);
    uint32_t isr = atomic_load_explicit(&ex_isr_total, memory_order_relaxed) - isr0;
    return n > isr ? n - isr : 0u;
}

static void ex_fail(const char *what, const char *prog)
{
    ef_m4_puts("m4_example: FAIL ");
    ef_m4_puts(prog);
    ef_m4_puts(": ");
    ef_m4_puts(what);
    ef_m4_puts("\n");
    ex_failed = 1u;
}

static void ex_check(int ok, const char *what, const char *prog)
{
    ex_checks++;
    if (!ok) {
        ex_fail(what, prog);
    }
}

static int ex_ring_full(void)
{
    uint32_t head = atomic_load_explicit(&ex_head, memory_order_relaxed);
    return head - atomic_load_explicit(&ex_tail, memory_order_acquire) >= EX_RING;
}

/* Pull moves into the ring until the smoother has none final or the ring is full (1). */
static int ex_pump(void)
{
    for (;;) {
        if (ex_ring_full()) {
            atomic_store_explicit(&ex_go, 1u, memory_order_release);
            return 1;
        }
        uint32_t head = atomic_load_explicit(&ex_head, memory_order_relaxed);
        uint32_t isr0 = atomic_load_explicit(&ex_isr_total, memory_order_relaxed);
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_smooth_pull(&ex_sm, &ex_ring[head % EX_RING]);
        uint32_t n = ex_cost(t0, isr0);
        if (rc != EF_OK) {
            return rc == EF_ERR_AGAIN ? 0 : -1;
        }
        if (n > ex_pull_prog) {
            ex_pull_prog = n;
        }
        /* Release: the slot is written before the consumer can see the new head. */
        atomic_store_explicit(&ex_head, head + 1u, memory_order_release);
    }
}

/* Wait for the interrupt to free a slot. A SysTick that lands between the test and the
 * wfi is not lost: the next one wakes us a period later. */
static void ex_wait(void)
{
    while (ex_ring_full()) {
        /* Idle time: the smoother's next work unit (ef_smooth_work()), so moves are built
         * ahead of the pulls; sleep only when it has none. */
        uint32_t isr0 = atomic_load_explicit(&ex_isr_total, memory_order_relaxed);
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_smooth_work(&ex_sm);
        uint32_t n = ex_cost(t0, isr0);
        if (n > ex_work_prog) {
            ex_work_prog = n;
        }
        if (rc == EF_OK) {
            ex_units++;
            continue;
        }
        __asm volatile("wfi" ::: "memory");
    }
}

/* Push pr, or finish when pr is NULL: one work unit a call (ef_smooth.h, "Work units"),
 * moving what is final into the ring between the calls while it returns EF_ERR_FULL; the
 * worst call's cost into *worst. */
static int ex_smooth(const ef_prim_t *pr, uint32_t *worst)
{
    for (;;) {
        uint32_t isr0 = atomic_load_explicit(&ex_isr_total, memory_order_relaxed);
        uint32_t t0 = ef_m4_icount_begin();
        int rc = pr ? ef_smooth_push(&ex_sm, pr) : ef_smooth_finish(&ex_sm);
        uint32_t n = ex_cost(t0, isr0);
        if (n > *worst) {
            *worst = n;
        }
        if (rc != EF_ERR_FULL) {
            return rc;
        }
        int p = ex_pump();
        if (p < 0) {
            return p;
        }
        if (p > 0) {
            ex_wait();
        }
    }
}

static int ex_push(const ef_prim_t *pr)
{
    return ex_smooth(pr, &ex_push_prog);
}

/* Finish until every pushed primitive is built into moves. */
static int ex_finish(void)
{
    return ex_smooth((const ef_prim_t *)0, &ex_fin_prog);
}

/* Move everything the smoother has final into the ring, waiting for room. */
static int ex_drain(void)
{
    int p;
    while ((p = ex_pump()) > 0) {
        ex_wait();
    }
    return p;
}

static void ex_systick(int on)
{
    EX_SYST_CSR = 0u;
    if (on) {
        EX_SYST_RVR = EX_SYSTICK_RELOAD;
        EX_SYST_CVR = 0u;
        EX_SYST_CSR = EX_SYST_ON;
    }
}

static void ex_run(const ef_golden_prog_t *pg)
{
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.g1 = &ef_tbl_g1_default;
    for (int k = 0; k < 3; k++) {
        cfg.lim.v_axis[k] = 200.0f;
        cfg.lim.a_axis[k] = 1000.0f;
    }
    cfg.lim.j_max = 20000.0f;
    cfg.lim.a_normal_frac = 0.5f;
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;

    /* SysTick is off: the background owns everything until it starts it. */
    ef_vec3_t home = ef_v3(0.0f, 0.0f, 0.0f), end = home;
    float feed_max = 0.0f;
    for (uint32_t i = 0; i < pg->n; i++) {
        if (pg->rec[i].op == EF_GOLDEN_PUSH) {
            feed_max = ef_maxf(feed_max, pg->rec[i].pr.feed);
            end = pg->rec[i].pr.end;
        }
    }
    /* The path speed never exceeds the programmed feed; 10 % for the corrected stepping's
     * residual, and a micrometre for rounding. */
    ex_step_lim = ef_minf(feed_max, 200.0f * 1.7320508f) * 1e-3f * 1.1f + 1e-3f;
    memset(&ex_isr, 0, sizeof ex_isr);
    ex_push_prog = 0u;
    ex_pull_prog = 0u;
    ex_fin_prog = 0u;
    ex_work_prog = 0u;
    ex_units = 0u;
    ex_isr.nprobe = 3u;
    ex_isr.last.p = home;
    atomic_store(&ex_head, 0u);
    atomic_store(&ex_tail, 0u);
    atomic_store(&ex_go, 0u);
    atomic_store(&ex_fed, 0u);
    atomic_store(&ex_end, 0u);
    if (ef_smooth_init(&ex_sm, &cfg, home) != EF_OK ||
        ef_interp_init(&ex_ip, home, EX_PERIOD_US, EF_STEP_CORRECTED) != EF_OK) {
        ex_fail("init", pg->name);
        return;
    }
    ex_systick(1);

    int rc = EF_OK;
    for (uint32_t i = 0; i < pg->n && rc == EF_OK; i++) {
        const ef_golden_rec_t *r = &pg->rec[i];
        if (r->op == EF_GOLDEN_FINISH) {
            rc = ex_finish();
        } else {
            rc = ex_push(&r->pr);
        }
        if (rc == EF_OK) {
            rc = ex_drain();
        }
    }
    if (rc == EF_OK) {
        rc = ex_finish();
    }
    if (rc == EF_OK) {
        rc = ex_drain();
    }
    atomic_store_explicit(&ex_go, 1u, memory_order_release);
    atomic_store_explicit(&ex_fed, 1u, memory_order_release);
    ex_check(rc == EF_OK, "the smoother refused the program", pg->name);
    if (rc == EF_OK) {
        /* Idle: wfi lets QEMU (-icount sleep=off) skip to the next tick. */
        while (!atomic_load_explicit(&ex_end, memory_order_acquire)) {
            __asm volatile("wfi" ::: "memory");
        }
    }
    ex_systick(0);

    const ex_isr_t *s = &ex_isr;
    ex_check(s->moving > 0u, "never moved", pg->name);
    ex_check(s->underruns == 0u, "underrun", pg->name);
    ex_check(s->errors == 0u, "push or process error", pg->name);
    ex_check(s->setpoints == s->periods, "a period without a setpoint", pg->name);
    ex_check(s->jumps == 0u, "a step longer than the fastest feed allows", pg->name);
    ex_check(ef_v3_norm(ef_v3_sub(s->last.p, end)) <= EF_INTERP_JOIN_TOL,
             "does not end where the program ends", pg->name);
    ex_check(!s->last.moving && s->last.v_plan == 0.0f, "not at rest at the end", pg->name);

    ef_m4_puts("m4_example: ");
    ef_m4_puts(pg->name);
    ef_m4_put_u32(" periods ", s->periods);
    ef_m4_put_u32("  moving periods ", s->moving);
    ef_m4_put_u32("  step max (um) ", (uint32_t)(s->step_max * 1000.0f + 0.5f));
    ef_m4_put_u32("  step limit (um) ", (uint32_t)(ex_step_lim * 1000.0f + 0.5f));
    ef_m4_put_u32("  isr worst (instructions) ", s->isr_worst);
    ef_m4_put_u32("  push worst (instructions) ", ex_push_prog);
    ef_m4_put_u32("  pull worst (instructions) ", ex_pull_prog);
    ef_m4_put_u32("  finish worst (instructions) ", ex_fin_prog);
    ef_m4_put_u32("  idle work units ", ex_units);
    ef_m4_put_u32("  work worst (instructions) ", ex_work_prog);
    ex_fin_worst = ex_fin_prog > ex_fin_worst ? ex_fin_prog : ex_fin_worst;
    ex_work_worst = ex_work_prog > ex_work_worst ? ex_work_prog : ex_work_worst;
    ex_units_all += ex_units;
    ex_isr_worst = s->isr_worst > ex_isr_worst ? s->isr_worst : ex_isr_worst;
    ex_push_worst = ex_push_prog > ex_push_worst ? ex_push_prog : ex_push_worst;
    ex_pull_worst = ex_pull_prog > ex_pull_worst ? ex_pull_prog : ex_pull_worst;
}

int main(void)
{
    ef_m4_icount_calibrate();
    ef_m4_stack_paint();

    /* The clock check: SysTick's period against timer 0, both 25 MHz of QEMU's virtual
     * clock if SysTick counts the processor clock. */
    ex_isr.nprobe = 0u;
    /* Busy, not wfi: QEMU 7.2 at -icount sleep=off wakes from wfi one SysTick late, so
     * ticks taken from wfi come 2 ms apart (measured; busy, they are 25 000 apart). */
    ex_systick(1);
    while (ex_isr.nprobe < 3u) {
        __asm volatile("" ::: "memory"); /* the interrupt writes it */
    }
    ex_systick(0);
    uint32_t ticks = ex_isr.probe[1] - ex_isr.probe[2]; /* timer 0 counts down */
    ef_m4_put_u32("m4_example: timer 0 ticks per SysTick period ", ticks);
    ex_check(ticks + 5u >= EX_SYSTICK_RELOAD + 1u && ticks <= EX_SYSTICK_RELOAD + 6u,
             "SysTick does not run at 25 MHz", "clock");

    for (uint32_t k = 0; k < ef_golden_nprogs; k++) {
        ex_run(&ef_golden_progs[k]);
    }
    ex_check(ef_m4_stack_intact() == 0, "stack overflow", "all");

    /* The counter's resolution at EF_M4_ICOUNT_SHIFT 3 is one timer tick, 5 instructions:
     * the figures are printed rounded up by one tick, as bounds. */
    ef_m4_put_u32("m4_example: isr worst (instructions) ", ex_isr_worst + EX_RES);
    ef_m4_put_u32("m4_example: push worst (instructions) ", ex_push_worst + EX_RES);
    ef_m4_put_u32("m4_example: pull worst (instructions) ", ex_pull_worst + EX_RES);
    ef_m4_put_u32("m4_example: finish worst (instructions) ", ex_fin_worst + EX_RES);
    ef_m4_put_u32("m4_example: work worst (instructions) ", ex_work_worst + EX_RES);
    ef_m4_put_u32("m4_example: idle work units ", ex_units_all);
    ef_m4_put_u32("m4_example: stack used (bytes) ", ef_m4_stack_used());
    ef_m4_put_u32("m4_example: checks ", ex_checks);
    if (ex_checks == 0u || ef_golden_nprogs == 0u) {
        ef_m4_puts("m4_example: FAIL no check ran\n");
        return 1;
    }
    if (ex_failed) {
        return 1;
    }
    ef_m4_puts("m4_example: ok\n");
    return 0;
}
