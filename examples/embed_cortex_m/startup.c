/*
 * The least a bare Cortex-M4 needs to run main() under QEMU: a vector table, the copy of
 * .data and the zeroing of .bss, the FPU switched on (CPACR: CP10 and CP11 full access),
 * and Arm semihosting (BKPT 0xAB) for text out and the exit status.  Nothing of eomc.
 */
#include <stdint.h>

#include "board.h"

extern uint32_t _estack, _sidata, _sdata, _edata, _sbss, _ebss;
int main(void);
void reset_handler(void);
static void fault_handler(void);

__attribute__((section(".isr_vector"), used))
static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_estack, reset_handler, fault_handler, fault_handler,
    fault_handler, fault_handler, fault_handler, 0, 0, 0, 0,
    fault_handler, fault_handler, 0, fault_handler, fault_handler,
};

static int semihost(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void board_write(const char *text)
{
    (void)semihost(0x04, (void *)(uintptr_t)text);   /* SYS_WRITE0 */
}

void board_exit(int status)
{
    uint32_t block[2] = {0x20026u, (uint32_t)status};   /* ADP_Stopped_ApplicationExit */
    (void)semihost(0x20, block);                          /* SYS_EXIT_EXTENDED */
    for (;;) {
    }
}

static void fault_handler(void)
{
    board_write("fault\n");
    board_exit(3);
}

/* SysTick on the processor clock: a 24-bit down-counter */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

uint32_t board_ticks(void)
{
    return SYST_CVR;
}

void reset_handler(void)
{
    uint32_t *src = &_sidata, *dst;
    for (dst = &_sdata; dst < &_edata; dst++) {
        *dst = *src++;
    }
    for (dst = &_sbss; dst < &_ebss; dst++) {
        *dst = 0u;
    }
    *(volatile uint32_t *)0xE000ED88u |= (0xFu << 20);   /* CPACR: the FPU */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    SYST_RVR = 0x00FFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = 5u;   /* enable, processor clock, no interrupt */
    board_exit(main());
}
