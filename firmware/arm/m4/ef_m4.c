/* SPDX-License-Identifier: Apache-2.0 */
/* Semihosting console and exit, the icount-based instruction counter and stack painting of
 * the Cortex-M4F test images (ef_m4.h). */
#include "ef_m4.h"

/* Semihosting operations (Arm "Semihosting for AArch32 and AArch64"). */
#define SH_SYS_WRITE0                   0x04u
#define SH_SYS_EXIT_EXTENDED            0x20u
#define SH_ADP_STOPPED_APPLICATION_EXIT 0x20026u

/* The BKPT 0xAB trap: QEMU (-semihosting-config enable=on) carries out the operation in r0
 * with the parameter in r1 and returns its result in r0. */
static uint32_t m4_semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm("r0") = op;
    register const void *r1 __asm("r1") = arg;
    __asm volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void ef_m4_puts(const char *s)
{
    (void)m4_semihost(SH_SYS_WRITE0, s);
}

char *ef_m4_fmt_u32(char *buf, uint32_t v)
{
    char tmp[10];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n > 0) {
        *buf++ = tmp[--n];
    }
    *buf = '\0';
    return buf;
}

char *ef_m4_fmt_x32(char *buf, uint32_t v)
{
    static const char hex[] = "0123456789abcdef";
    for (int i = 7; i >= 0; i--) {
        *buf++ = hex[(v >> (4 * i)) & 0xFu];
    }
    *buf = '\0';
    return buf;
}

void ef_m4_put_u32(const char *s, uint32_t v)
{
    char buf[12];
    char *e = ef_m4_fmt_u32(buf, v);
    e[0] = '\n';
    e[1] = '\0';
    ef_m4_puts(s);
    ef_m4_puts(buf);
}

void ef_m4_exit(int status)
{
    /* SYS_EXIT_EXTENDED takes a block {reason, subcode}; QEMU exits with the subcode. */
    static volatile uint32_t block[2];
    block[0] = SH_ADP_STOPPED_APPLICATION_EXIT;
    block[1] = (uint32_t)status;
    for (;;) {
        (void)m4_semihost(SH_SYS_EXIT_EXTENDED, (const void *)block);
    }
}

/* CMSDK APB timer 0 of the MPS2 board, clocked at 25 MHz. */
#define M4_TIMER0_CTRL   (*(volatile uint32_t *)0x40000000u)
#define M4_TIMER0_VALUE  (*(volatile uint32_t *)0x40000004u)
#define M4_TIMER0_RELOAD (*(volatile uint32_t *)0x40000008u)

static uint32_t m4_icount_overhead;

/* Not inlined, here or anywhere: the calibration must measure the same call sequence the
 * callers pay. */
__attribute__((noinline)) uint32_t ef_m4_icount_begin(void)
{
    return M4_TIMER0_VALUE;
}

/* Timer ticks to instructions: 2^shift ns per instruction, 40 ns per tick, rounded. */
static uint32_t m4_ticks_to_instr(uint32_t ticks)
{
    uint64_t num = (uint64_t)ticks * 40u;
    return (uint32_t)((num + (1u << (EF_M4_ICOUNT_SHIFT - 1))) >> EF_M4_ICOUNT_SHIFT);
}

__attribute__((noinline)) uint32_t ef_m4_icount_end(uint32_t t0)
{
    uint32_t t1 = M4_TIMER0_VALUE;
    uint32_t n = m4_ticks_to_instr(t0 - t1); /* counts down; wrap-safe */
    return n > m4_icount_overhead ? n - m4_icount_overhead : 0u;
}

void ef_m4_icount_calibrate(void)
{
    M4_TIMER0_CTRL = 0u;
    M4_TIMER0_RELOAD = 0xFFFFFFFFu;
    M4_TIMER0_VALUE = 0xFFFFFFFFu;
    M4_TIMER0_CTRL = 1u;
    m4_icount_overhead = 0u;
    uint32_t least = 0xFFFFFFFFu;
    for (int i = 0; i < 8; i++) {
        uint32_t t0 = ef_m4_icount_begin();
        uint32_t n = ef_m4_icount_end(t0);
        if (n < least) {
            least = n;
        }
    }
    m4_icount_overhead = least;
}

#define M4_PAINT 0xC5C5C5C5u
extern uint32_t _sstack;
/* Stack pointer at the last paint: the reference the high-water mark is measured from. */
uint32_t ef_m4_stack_ref;

/* Naked: it must not use the stack it paints. Paints [_sstack, sp) and records sp. */
__attribute__((naked)) void ef_m4_stack_paint(void)
{
    __asm volatile("ldr r0, =_sstack\n\t"
                   "mov r1, sp\n\t"
                   "ldr r2, =0xC5C5C5C5\n\t"
                   "ldr r3, =ef_m4_stack_ref\n\t"
                   "str r1, [r3]\n"
                   "1:\n\t"
                   "cmp r0, r1\n\t"
                   "bhs 2f\n\t"
                   "str r2, [r0], #4\n\t"
                   "b 1b\n"
                   "2:\n\t"
                   "bx lr\n\t"
                   ".ltorg");
}

uint32_t ef_m4_stack_used(void)
{
    const uint32_t *p = &_sstack;
    const uint32_t *ref = (const uint32_t *)ef_m4_stack_ref;
    while (p < ref && *p == M4_PAINT) {
        p++;
    }
    return (uint32_t)((const char *)ref - (const char *)p);
}

int ef_m4_stack_intact(void)
{
    return (&_sstack)[0] == M4_PAINT ? 0 : -1;
}
