/* PIL start-up for QEMU's MPS2 boards (harness only, not shipped): the vector table, and a reset
 * handler that gives the FPU full access (CPACR CP10/CP11) and then calls newlib's semihosting
 * _start (which sets up the stack and heap, runs main and exits through semihosting). */
#include <stdint.h>

extern void _start(void);
extern uint32_t __stack_top;

void vse_pil_reset(void);
void vse_pil_fault(void);

void vse_pil_reset(void)
{
    volatile uint32_t *const cpacr = (volatile uint32_t *)0xE000ED88u;
    *cpacr |= (0xFu << 20);
    __asm volatile ("dsb\n\tisb" ::: "memory");
    _start();
    for (;;) {
    }
}

/* Faults stop here; the host sees QEMU time out. */
void vse_pil_fault(void)
{
    for (;;) {
    }
}

/* Initial stack pointer, reset, NMI, hard fault, memory management, bus and usage fault,
 * 4 reserved, SVCall, debug monitor, reserved, PendSV, SysTick. */
__attribute__((section(".vectors"), used))
static const uintptr_t vse_pil_vectors[16] = {
    (uintptr_t)&__stack_top, (uintptr_t)vse_pil_reset,
    (uintptr_t)vse_pil_fault, (uintptr_t)vse_pil_fault, (uintptr_t)vse_pil_fault,
    (uintptr_t)vse_pil_fault, (uintptr_t)vse_pil_fault, 0u, 0u, 0u, 0u,
    (uintptr_t)vse_pil_fault, (uintptr_t)vse_pil_fault, 0u,
    (uintptr_t)vse_pil_fault, (uintptr_t)vse_pil_fault,
};
