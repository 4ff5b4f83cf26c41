/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The M4 board support checks itself before anything is measured with it (ef_m4.h):
 * the semihosting console, the instruction counter exact on instruction sequences of known
 * length (straight-line NOPs, a counted loop whose instructions are fixed by inline
 * assembly), the FPU enabled, stack painting, and the exit status (the run script expects
 * 0 and a final "m4_selftest: ok").
 */
#include <stdint.h>
#include "ef_m4.h"

static int st_fails;
static int st_checks;

static void st_expect(const char *what, uint32_t got, uint32_t want)
{
    st_checks++;
    if (got != want) {
        st_fails++;
        ef_m4_puts("FAIL ");
        ef_m4_puts(what);
        ef_m4_put_u32(": got ", got);
        ef_m4_put_u32("  want ", want);
    }
}

/* n iterations of exactly 2 instructions (subs, bne) plus 1 (mov) before them. */
__attribute__((noinline)) static void st_loop(uint32_t n)
{
    __asm volatile("mov r3, %0\n"
                   "1:\n\t"
                   "subs r3, r3, #1\n\t"
                   "bne 1b"
                   :
                   : "r"(n)
                   : "r3", "cc");
}

/* Deeper than 256 bytes of stack, written. */
__attribute__((noinline)) static uint32_t st_deep(volatile uint32_t *sink)
{
    volatile uint32_t buf[64];
    for (uint32_t i = 0; i < 64u; i++) {
        buf[i] = i;
    }
    *sink = buf[63];
    return buf[0];
}

int main(void)
{
    ef_m4_puts("m4_selftest: mps2-an386, semihosting console up\n");
    ef_m4_icount_calibrate();

    uint32_t t0 = ef_m4_icount_begin();
    uint32_t n = ef_m4_icount_end(t0);
    st_expect("empty measurement", n, 0u);

    t0 = ef_m4_icount_begin();
    __asm volatile("nop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop");
    n = ef_m4_icount_end(t0);
    st_expect("10 nops", n, 10u);

    /* A call of st_loop(k) costs a fixed c + 2k; two lengths give c, a third checks it. */
    uint32_t n100, n1000, n54321;
    t0 = ef_m4_icount_begin();
    st_loop(100u);
    n100 = ef_m4_icount_end(t0);
    t0 = ef_m4_icount_begin();
    st_loop(1000u);
    n1000 = ef_m4_icount_end(t0);
    st_expect("loop 1000 - loop 100", n1000 - n100, 1800u);
    t0 = ef_m4_icount_begin();
    st_loop(54321u);
    n54321 = ef_m4_icount_end(t0);
    st_expect("loop 54321 - loop 100", n54321 - n100, 2u * (54321u - 100u));

    volatile float f = 1.5f;
    f = f * 3.0f;
    st_expect("FPU: 1.5 * 3", (uint32_t)f, 4u);

    volatile uint32_t sink;
    ef_m4_stack_paint();
    (void)st_deep(&sink);
    uint32_t used = ef_m4_stack_used();
    st_checks++;
    if (used < 256u || used > 512u) {
        st_fails++;
        ef_m4_put_u32("FAIL stack high-water of a 256-byte frame: ", used);
    }
    st_expect("stack bottom intact", (uint32_t)ef_m4_stack_intact(), 0u);

    ef_m4_put_u32("m4_selftest: instructions of a call of st_loop(100): ", n100);
    ef_m4_put_u32("m4_selftest: stack of a 256-byte frame: ", used);
    if (st_fails != 0 || st_checks == 0) {
        ef_m4_put_u32("m4_selftest: FAILED checks: ", (uint32_t)st_fails);
        return 1;
    }
    ef_m4_put_u32("m4_selftest: ok, checks: ", (uint32_t)st_checks);
    return 0;
}
