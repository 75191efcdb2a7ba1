/* roadvo on a Cortex-M7 from C, as an ECU written in C integrates it: the odometer's storage a
   zero-initialised static of ROADVO_ODOMETER_SIZE bytes, the configuration compiled in (the words
   `roadvo export-config MOUNT --c` wrote) and validated once at boot, then one roadvo_process()
   per camera frame.

   The camera is stood in for by a drive recorded by `roadvo pack` in the board's frame memory
   (scripts/firmware-c loads it into QEMU's PSRAM and compares what this prints with the host's
   `roadvo run --trace`, bit for bit). Each estimate, and each smoothed one, is printed as its
   trace record. Exit status 0 when the drive is done, 1 on any error. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "board.h"
#include "roadvo.h"
#include ROADVO_CONFIG_HEADER /* static const uint32_t roadvo_config[] */

/* The frame store's layout (the core's roadvo::wire::frame_store, version 2): a header of
   magic, version, header size, first row, rows, frames and the configuration's words, then each
   frame's timestamp (u64, microseconds) and its rows. Little-endian, as this core is. */
#define STORE_VERSION 2u
#define STORE_HEADER_BYTES (16u + 4u * ROADVO_CONFIG_WORDS)

/* The odometer's storage: in .bss (no flash, no copy at reset), never on the stack. */
static _Alignas(ROADVO_ODOMETER_ALIGN) uint8_t odometer_storage[ROADVO_ODOMETER_SIZE];

/* Instruction counter markers (scripts/qemu-icount counts from the entry of the first to the
   entry of the second); unlike bodies so that the linker never merges them. */
__attribute__((noinline)) void roadvo_frame_begin(void) { __asm__ volatile("nop" ::: "memory"); }
__attribute__((noinline)) void roadvo_frame_end(void) {
    __asm__ volatile("nop\n nop" ::: "memory");
}

static uint32_t read_u32(const uint8_t *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint16_t read_u16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

/* Appends the decimal digits of `v` at `out`; returns the end. */
static char *put_u32(char *out, uint32_t v) {
    char digits[10];
    int n = 0;
    do {
        digits[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n > 0) {
        *out++ = digits[--n];
    }
    return out;
}

static char *put_text(char *out, const char *text) {
    while (*text != '\0') {
        *out++ = *text++;
    }
    return out;
}

/* Prints `kind index word...`, the trace line `roadvo run --trace` writes. */
static void print_trace(const char *kind, uint32_t index, const RoadvoEstimate *e) {
    uint32_t words[ROADVO_TRACE_WORDS];
    char line[16 + 11 * (ROADVO_TRACE_WORDS + 1)];
    roadvo_trace_record(e, words);
    char *p = put_u32(put_text(put_text(line, kind), " "), index);
    for (size_t i = 0; i < ROADVO_TRACE_WORDS; i++) {
        p = put_u32(put_text(p, " "), words[i]);
    }
    *p++ = '\n';
    *p = '\0';
    board_write(line);
}

static void print_value(const char *before, uint32_t value, const char *after) {
    char line[160];
    char *p = put_text(put_u32(put_text(line, before), value), after);
    *p = '\0';
    board_write(line);
}

/* Saves the mount the odometer learned while driving, as an ECU keeps it in non-volatile memory
   for the next ignition, and gives it back as the next start would; prints the bytes. */
static bool keep_calibration(RoadvoOdometer *odometer) {
    static const char hex[] = "0123456789abcdef";
    uint8_t saved[ROADVO_CALIBRATION_BYTES];
    char line[32 + 3 * ROADVO_CALIBRATION_BYTES];
    RoadvoStatus s = roadvo_calibration_save(odometer, saved);
    if (s == ROADVO_STATUS_OK) {
        s = roadvo_calibration_restore(odometer, saved);
    }
    if (s != ROADVO_STATUS_OK) {
        board_write("calibration not kept: ");
        board_write(roadvo_status_text(s));
        board_write("\n");
        return false;
    }
    char *p = put_text(line, "learned mount saved as");
    for (size_t i = 0; i < ROADVO_CALIBRATION_BYTES; i++) {
        *p++ = ' ';
        *p++ = hex[saved[i] >> 4];
        *p++ = hex[saved[i] & 15u];
    }
    *p++ = '\n';
    *p = '\0';
    board_write(line);
    return true;
}

/* Prints the odometer's last error and `what`. */
static void print_error(const RoadvoOdometer *odometer, const char *what, RoadvoStatus status) {
    char reason[160];
    roadvo_describe(odometer, reason, sizeof reason);
    board_write(what);
    board_write(": ");
    board_write(roadvo_status_text(status));
    board_write(" (");
    board_write(reason);
    board_write(")\n");
}

/* Validates the configuration compiled in and gives it to the odometer, once at boot. */
static RoadvoOdometer *boot(void) {
    RoadvoOdometer *odometer = NULL;
    RoadvoStatus s = roadvo_odometer_init(odometer_storage, sizeof odometer_storage, &odometer);
    if (s != ROADVO_STATUS_OK) {
        board_write("no odometer: ");
        board_write(roadvo_status_text(s));
        board_write("\n");
        return NULL;
    }
    s = roadvo_configure(odometer, roadvo_config, ROADVO_CONFIG_WORDS);
    if (s != ROADVO_STATUS_OK) {
        print_error(odometer, "configuration refused at boot", s);
        return NULL;
    }
    return odometer;
}

/* Replays the drive in the frame memory, printing every estimate. */
static bool replay(RoadvoOdometer *odometer) {
    size_t len = 0;
    const uint8_t *memory = board_camera_memory(&len);
    if (len < STORE_HEADER_BYTES || memcmp(memory, "RVFS", 4) != 0 ||
        read_u16(memory + 4) != STORE_VERSION || read_u16(memory + 6) != STORE_HEADER_BYTES) {
        board_write("replay stopped: no frame store of this version in the frame memory\n");
        return false;
    }
    uint16_t first_row = read_u16(memory + 8), rows = read_u16(memory + 10);
    uint32_t frames = read_u32(memory + 12);
    for (size_t i = 0; i < ROADVO_CONFIG_WORDS; i++) {
        if (read_u32(memory + 16 + 4 * i) != roadvo_config[i]) {
            board_write("replay stopped: the drive was packed with another configuration\n");
            return false;
        }
    }
    uint16_t width = 0, height = 0, read_first = 0, read_end = 0;
    roadvo_image_size(odometer, &width, &height);
    roadvo_rows_read(odometer, &read_first, &read_end);
    size_t frame_bytes = 8u + (size_t)rows * width;
    if (read_first < first_row || read_end > first_row + rows ||
        frames > (len - STORE_HEADER_BYTES) / frame_bytes) {
        board_write("replay stopped: the stored rows or frames do not fit\n");
        return false;
    }
    print_value("odometer ", ROADVO_ODOMETER_SIZE, " bytes, ");
    print_value("reading rows ", read_first, "..");
    print_value("", read_end, "\n");
    uint8_t lag = roadvo_smoothing_lag(odometer);
    uint32_t smoothed = 0;
    RoadvoEstimate e;
    for (uint32_t i = 0; i < frames; i++) {
        const uint8_t *stored = memory + STORE_HEADER_BYTES + (size_t)i * frame_bytes;
        uint64_t timestamp_us = (uint64_t)read_u32(stored) | (uint64_t)read_u32(stored + 4) << 32;
        /* The band of rows the camera's readout window delivered: the others read as black. */
        RoadvoFrame frame = {
            .width = width,
            .height = height,
            .data = stored + 8,
            .stride = width,
            .first_row = first_row,
            .rows = rows,
            .row = NULL,
            .context = NULL,
        };
        roadvo_frame_begin();
        RoadvoStatus s = roadvo_process(odometer, &frame, timestamp_us, &e);
        roadvo_frame_end();
        if (s != ROADVO_STATUS_OK) {
            print_value("frame ", i, "\n");
            print_error(odometer, "replay stopped", s);
            return false;
        }
        print_trace("estimate", i, &e);
        if (lag > 0 && roadvo_smoothed(odometer, &e) == ROADVO_STATUS_OK) {
            print_trace("smoothed", smoothed++, &e);
        }
    }
    while (lag > 0 && roadvo_flush(odometer, &e) == ROADVO_STATUS_OK) {
        print_trace("smoothed", smoothed++, &e);
    }
    print_value("drive done: ", frames, " frames\n");
    return keep_calibration(odometer);
}

int main(void) {
    RoadvoOdometer *odometer = boot();
    bool ok = odometer != NULL && replay(odometer);
    print_value("stack high-water mark ", (uint32_t)board_stack_high_water(), " bytes\n");
    return ok ? 0 : 1;
}
