/* Start-up for a Cortex-M7 (QEMU mps2-an500): the vector table, the reset handler (copy .data,
   zero .bss, switch the FPU on, paint the stack), and semihosting for output and exit. */
#include "board.h"

#include <stdint.h>

int main(void);

extern uint32_t _data_start, _data_end, _data_load, _bss_start, _bss_end;
extern uint32_t _stack_bottom, _stack_top;
extern const uint8_t _camera_memory_start, _camera_memory_end;

#define STACK_PAINT 0xCCCCCCCCu

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

static uintptr_t semihosting(uintptr_t op, const void *arg) {
    register uintptr_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* The host's standard output: ":tt" opened for writing, as cortex-m-semihosting's hstdout. */
static uintptr_t host_stdout = (uintptr_t)-1;

void board_write(const char *text) {
    if (host_stdout == (uintptr_t)-1) {
        const uintptr_t open_args[3] = {(uintptr_t)":tt", 4 /* "w" */, 3 /* strlen(":tt") */};
        host_stdout = semihosting(0x01 /* SYS_OPEN */, open_args);
    }
    size_t len = 0;
    while (text[len] != '\0') {
        len++;
    }
    const uintptr_t write_args[3] = {host_stdout, (uintptr_t)text, len};
    semihosting(0x05 /* SYS_WRITE */, write_args);
}

void board_exit(int success) {
    /* ADP_Stopped_ApplicationExit, or ADP_Stopped_RunTimeErrorUnknown. */
    uintptr_t reason = success ? 0x20026u : 0x20023u;
    semihosting(0x18 /* SYS_EXIT */, (const void *)reason);
    for (;;) {
        __asm__ volatile("wfi");
    }
}

size_t board_stack_high_water(void) {
    const uint32_t *p = &_stack_bottom;
    while (p < &_stack_top && *p == STACK_PAINT) {
        p++;
    }
    return (size_t)((const uint8_t *)&_stack_top - (const uint8_t *)p);
}

const uint8_t *board_camera_memory(size_t *len) {
    *len = (size_t)(&_camera_memory_end - &_camera_memory_start);
    return &_camera_memory_start;
}
