/* The board: the stack's high-water mark, semihosting (output to the host, exit). */
#ifndef BOARD_H
#define BOARD_H

#include <stddef.h>
#include <stdint.h>

/* Writes a NUL-terminated string to the host's standard output. */
void board_write(const char *text);

/* Ends the run: QEMU exits with 0 for success, 1 otherwise. */
void board_exit(int success) __attribute__((noreturn));

/* Deepest the stack has been since reset, bytes. */
size_t board_stack_high_water(void);

/* The camera's frame memory (PSRAM). */
const uint8_t *board_camera_memory(size_t *len);

#endif
