/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Reset code and vector table of the Cortex-M4F test images (ef_m4.h). The reset handler
 * does what a board's startup must before C code runs: copy .data from its load address,
 * zero .bss, and give the FPU full access (CPACR CP10/CP11) before the first floating-point
 * instruction. main's return value becomes the emulator's exit status. A fault prints its
 * name and ends the run with status 3, so a crash is a failed test, never a hang.
 *
 * Handlers an image does not define (SysTick_Handler in firmware/examples/, say) are weak
 * aliases of the default one.
 */
#include <stdint.h>
#include "ef_m4.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void HardFault_Handler(void) __attribute__((weak));
void MemManage_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void BusFault_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void UsageFault_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void DebugMon_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));

#define M4_CPACR (*(volatile uint32_t *)0xE000ED88u)
/* Configurable Fault Status Register: which fault, for the message. */
#define M4_CFSR (*(volatile uint32_t *)0xE000ED28u)

void Reset_Handler(void)
{
    const uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0u;
    }
    M4_CPACR |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    ef_m4_exit(main());
}

void Default_Handler(void)
{
    ef_m4_puts("m4: unexpected exception\n");
    ef_m4_exit(3);
}

void HardFault_Handler(void)
{
    ef_m4_put_u32("m4: fault, CFSR ", M4_CFSR);
    ef_m4_exit(3);
}

typedef union {
    uint32_t *stack;
    void (*handler)(void);
} m4_vector_t;

/* The 16 system vectors; the images use no device interrupt. */
__attribute__((section(".isr_vector"), used)) static const m4_vector_t m4_vectors[16] = {
    {.stack = &_estack},
    {.handler = Reset_Handler},
    {.handler = NMI_Handler},
    {.handler = HardFault_Handler},
    {.handler = MemManage_Handler},
    {.handler = BusFault_Handler},
    {.handler = UsageFault_Handler},
    {.handler = 0},
    {.handler = 0},
    {.handler = 0},
    {.handler = 0},
    {.handler = SVC_Handler},
    {.handler = DebugMon_Handler},
    {.handler = 0},
    {.handler = PendSV_Handler},
    {.handler = SysTick_Handler},
};
