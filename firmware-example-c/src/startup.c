/* Start-up for a Cortex-M7 (QEMU mps2-an500): the vector table and the reset handler (paint the
   stack, copy .data, zero .bss, switch the FPU on), which runs main and ends the run with its
   result. */
#include "board.h"

#include <stdint.h>

int main(void);

extern uint32_t _data_start, _data_end, _data_load, _bss_start, _bss_end;
extern uint32_t _stack_top;

void reset_handler(void) __attribute__((noreturn, naked));
static void start(void) __attribute__((noreturn, used));
static void fault_handler(void) __attribute__((noreturn));

__attribute__((section(".vector_table"), used))
static const void *const vector_table[16] = {
    &_stack_top,   reset_handler, fault_handler, fault_handler, fault_handler, fault_handler,
    fault_handler, 0,             0,             0,             0,             fault_handler,
    fault_handler, 0,             fault_handler, fault_handler,
};

/* Naked: paints the stack before anything runs on it, then starts. */
void reset_handler(void) {
    __asm__ volatile(
        "ldr r0, =_stack_bottom\n"
        "mov r1, sp\n"
        "ldr r2, =0xCCCCCCCC\n"
        "1: cmp r0, r1\n"
        "bhs 2f\n"
        "str r2, [r0], #4\n"
        "b 1b\n"
        "2: b start\n"
        ".ltorg\n");
}

static void start(void) {
    for (uint32_t *s = &_data_load, *d = &_data_start; d < &_data_end;) {
        *d++ = *s++;
    }
    for (uint32_t *d = &_bss_start; d < &_bss_end;) {
        *d++ = 0;
    }
    /* CP10 and CP11 full access: the FPU, which the library's hard-float code uses. */
    volatile uint32_t *cpacr = (volatile uint32_t *)0xE000ED88u;
    *cpacr |= 0xFu << 20;
    __asm__ volatile("dsb\n isb" ::: "memory");
    board_exit(main() == 0);
}

static void fault_handler(void) {
    board_write("fault\n");
    board_exit(0);
}

