/* roadvo's C API from C on the host: the storage checks, a configuration refused with its
   reason (a NaN, a window outside the image, a bad word, the wrong count), frames by buffer and
   by row function giving the same estimates, refused frames, the smoother's count. Built and
   run by scripts/firmware-c against the host's libroadvo_c.a and the KITTI clip's exported
   configuration; prints "N passed, 0 failed". */
#include <math.h>
#include <stdalign.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "roadvo.h"
#include ROADVO_CONFIG_HEADER

static int passed, failed;

#define CHECK(cond)                                                                    \
    do {                                                                               \
        if (cond) {                                                                    \
            passed++;                                                                  \
        } else {                                                                       \
            failed++;                                                                  \
            fprintf(stderr, "%s:%d: failed: %s\n", __FILE__, __LINE__, #cond);         \
        }                                                                              \
    } while (0)

static alignas(ROADVO_ODOMETER_ALIGN) uint8_t storage[ROADVO_ODOMETER_SIZE + 8];
/* Frames of the exported camera (at most KITTI's 1241x376). */
static uint8_t image[2][376 * 1241];
static uint16_t width = 1241, height = 376;

static uint32_t bits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* A configuration refused with `status` and a reason holding `says`. */
static void refused(RoadvoOdometer *odo, const uint32_t *words, RoadvoStatus status,
                    const char *says) {
    char reason[160];
    RoadvoStatus s = roadvo_configure(odo, words, ROADVO_CONFIG_WORDS);
    roadvo_describe(odo, reason, sizeof reason);
    printf("refused (%s): %s\n", roadvo_status_text(s), reason);
    CHECK(s == status);
    CHECK(strstr(reason, says) != NULL);
}

static const uint8_t *row_of(const void *context, uint16_t y) {
    return (const uint8_t *)context + (size_t)y * width;
}

int main(void) {
    RoadvoOdometer *odo = NULL;
    CHECK(roadvo_odometer_size() == ROADVO_ODOMETER_SIZE);
    CHECK(roadvo_odometer_init(storage, ROADVO_ODOMETER_SIZE - 1, &odo) ==
          ROADVO_STATUS_STORAGE_TOO_SMALL);
    CHECK(roadvo_odometer_init(storage + 4, ROADVO_ODOMETER_SIZE, &odo) ==
          ROADVO_STATUS_STORAGE_MISALIGNED);
    CHECK(roadvo_odometer_init(NULL, ROADVO_ODOMETER_SIZE, &odo) == ROADVO_STATUS_NULL_POINTER);
    CHECK(roadvo_odometer_init(storage, ROADVO_ODOMETER_SIZE, &odo) == ROADVO_STATUS_OK);

    RoadvoEstimate e;
    RoadvoFrame frame = {.width = 1241, .height = 376, .data = image[0], .stride = 1241,
                         .first_row = 0, .rows = 376, .row = NULL, .context = NULL};
    CHECK(roadvo_process(odo, &frame, 0, &e) == ROADVO_STATUS_NOT_CONFIGURED);

    uint32_t words[ROADVO_CONFIG_WORDS];
    memcpy(words, roadvo_config, sizeof words);
    words[ROADVO_CONFIG_MOUNT_HEIGHT_M] = bits(NAN);
    refused(odo, words, ROADVO_STATUS_NON_FINITE, "height_m is not a finite number");
    memcpy(words, roadvo_config, sizeof words);
    words[ROADVO_CONFIG_MOUNT_PITCH_DEG] = bits(30.0f * 3.14159265f / 180.0f);
    refused(odo, words, ROADVO_STATUS_ROI_OUTSIDE_IMAGE, "not visible in the image");
    memcpy(words, roadvo_config, sizeof words);
    words[ROADVO_CONFIG_ODOMETER_WINDOW_FAR_M] = bits(500.0f);
    refused(odo, words, ROADVO_STATUS_OUT_OF_RANGE, "window_far_m is out of range");
    memcpy(words, roadvo_config, sizeof words);
    words[ROADVO_CONFIG_ODOMETER_METHOD] = 7;
    refused(odo, words, ROADVO_STATUS_CONFIG_BAD_WORD, "makes no value of its setting");
    CHECK(roadvo_configure(odo, roadvo_config, ROADVO_CONFIG_WORDS - 1) ==
          ROADVO_STATUS_CONFIG_LENGTH);
    CHECK(roadvo_configure(odo, roadvo_config, ROADVO_CONFIG_WORDS) == ROADVO_STATUS_OK);
    CHECK(roadvo_image_size(odo, &width, &height) == ROADVO_STATUS_OK);
    CHECK((size_t)width * height <= sizeof image[0]);
    frame.width = width;
    frame.height = height;
    frame.stride = width;
    frame.rows = height;

    /* A second odometer, fed the same frames through a row function. */
    static alignas(ROADVO_ODOMETER_ALIGN) uint8_t storage2[ROADVO_ODOMETER_SIZE];
    RoadvoOdometer *by_rows = NULL;
    CHECK(roadvo_odometer_init(storage2, sizeof storage2, &by_rows) == ROADVO_STATUS_OK);
    CHECK(roadvo_configure(by_rows, roadvo_config, ROADVO_CONFIG_WORDS) == ROADVO_STATUS_OK);

    uint8_t lag = roadvo_smoothing_lag(odo);
    int frames = 8, smoothed = 0, same = 1;
    for (int i = 0; i < frames; i++) {
        uint8_t *img = image[i % 2];
        for (int v = 0; v < height; v++) {
            for (int u = 0; u < width; u++) {
                int vv = v + 2 * i;
                img[v * width + u] = (uint8_t)(((u / 24 + vv / 24) % 2) ? 200 : 40);
            }
        }
        uint64_t t = 100000u * (uint64_t)i;
        frame.data = img;
        CHECK(roadvo_process(odo, &frame, t, &e) == ROADVO_STATUS_OK);
        RoadvoFrame f2 = {.width = width, .height = height, .row = row_of, .context = img};
        RoadvoEstimate e2;
        CHECK(roadvo_process(by_rows, &f2, t, &e2) == ROADVO_STATUS_OK);
        uint32_t w1[ROADVO_TRACE_WORDS], w2[ROADVO_TRACE_WORDS];
        roadvo_trace_record(&e, w1);
        roadvo_trace_record(&e2, w2);
        same &= memcmp(w1, w2, sizeof w1) == 0;
        if (roadvo_smoothed(odo, &e2) == ROADVO_STATUS_OK) {
            smoothed++;
        }
        /* Refused, and the odometer unchanged: the same time again, a smaller frame. */
        CHECK(roadvo_process(odo, &frame, t, &e2) == ROADVO_STATUS_TIMESTAMP_NOT_INCREASING);
        RoadvoFrame small = frame;
        small.width = (uint16_t)(width - 1);
        CHECK(roadvo_process(odo, &small, t + 1, &e2) == ROADVO_STATUS_WRONG_SIZE);
    }
    CHECK(same);
    while (roadvo_flush(odo, &e) == ROADVO_STATUS_OK) {
        smoothed++;
    }
    CHECK(smoothed == (lag > 0 ? frames : 0));
    CHECK(roadvo_reset(odo) == ROADVO_STATUS_OK);
    CHECK(roadvo_process(odo, &frame, 0, &e) == ROADVO_STATUS_OK && e.startup);
    CHECK(roadvo_process(NULL, &frame, 0, &e) == ROADVO_STATUS_NULL_POINTER);
    CHECK(roadvo_process(odo, NULL, 1, &e) == ROADVO_STATUS_NULL_POINTER);

    printf("c-api: %d passed, %d failed\n", passed, failed);
    return failed == 0 ? 0 : 1;
}
