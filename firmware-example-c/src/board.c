/* The board (QEMU mps2-an500): semihosting for output and exit, the stack's high-water mark, the
   camera's frame memory. Start-up is startup.c's. */
#include "board.h"

#include <stdint.h>

extern uint32_t _stack_bottom, _stack_top;
extern const uint8_t _camera_memory_start, _camera_memory_end;

#define STACK_PAINT 0xCCCCCCCCu

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
