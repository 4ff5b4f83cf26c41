/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_m4.h
 * @brief Board support of the Cortex-M4F test images run under QEMU (`-M mps2-an386`):
 * reset and vector table (ef_m4_startup.c), a semihosting console and exit status, an
 * instruction counter, and stack painting. Not part of the firmware library: a product
 * brings its own startup; this is what the tests and firmware/examples/ run on.
 *
 * ## Instruction counting
 * Debian's QEMU has no TCG plugins. Run with `-icount shift=EF_M4_ICOUNT_SHIFT,sleep=off`
 * the emulator's virtual clock advances by exactly 2^shift ns per executed instruction, and
 * a device register read is the last instruction of its translation block, so the clock it
 * sees is exact. The board's CMSDK timer 0 (0x40000000) counts down at 25 MHz of that
 * clock, 2^shift * 25e6 / 1e9 ticks per instruction (25.6 with shift 10), so a difference of
 * two reads, divided by that and less the cost of the reads themselves (calibrated at start,
 * ef_m4_icount_calibrate()), is the number of instructions executed in between. On real
 * silicon the same code reads cycles' worth of a 25 MHz timer, which is meaningless: the
 * counter is only for the emulator.
 *
 * ## Context
 * Everything here runs in thread mode from main, except that ef_m4_exit() may also be
 * called from a handler (the fault handlers do).
 */
#ifndef EF_M4_H
#define EF_M4_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** icount shift the run script passes to QEMU (`-icount shift=10`): 1024 ns per instruction. */
#ifndef EF_M4_ICOUNT_SHIFT
#define EF_M4_ICOUNT_SHIFT 10
#endif

/** Write a NUL-terminated string to the semihosting console (host stdout). */
void ef_m4_puts(const char *s);
/** Write s, then an unsigned decimal, then a newline. */
void ef_m4_put_u32(const char *s, uint32_t v);
/** Format an unsigned decimal into buf (at least 11 bytes); returns the end (NUL). */
char *ef_m4_fmt_u32(char *buf, uint32_t v);
/** Format 8 lower-case hex digits into buf (at least 9 bytes); returns the end (NUL). */
char *ef_m4_fmt_x32(char *buf, uint32_t v);

/** End the emulation with this exit status (semihosting SYS_EXIT_EXTENDED). Never returns. */
void ef_m4_exit(int status) __attribute__((noreturn));

/** Start the instruction counter (timer 0 free-running from 0xffffffff) and measure the
 *  cost of one empty ef_m4_icount_begin() / ef_m4_icount_end() pair. Call once from main. */
void ef_m4_icount_calibrate(void);
/** Timer reading to pass to ef_m4_icount_end(). */
uint32_t ef_m4_icount_begin(void);
/** Instructions executed since the ef_m4_icount_begin() that returned t0, less the
 *  measurement's own (calibrated) instructions. */
uint32_t ef_m4_icount_end(uint32_t t0);

/** Paint the unused stack below the current stack pointer (less a small guard) with the
 *  paint word, so that ef_m4_stack_used() afterwards tells the deepest use since. */
void ef_m4_stack_paint(void);
/** Bytes of stack below the point of the last ef_m4_stack_paint() call that were written
 *  since (the high-water mark of what ran in between, relative to the painting frame). */
uint32_t ef_m4_stack_used(void);
/** 0 if the bottom word of the stack still holds the paint (no overflow), else -1. */
int ef_m4_stack_intact(void);

#ifdef __cplusplus
}
#endif

#endif /* EF_M4_H */
