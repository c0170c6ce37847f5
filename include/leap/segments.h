/* Ray events and segments: what the raster pass records per pixel and the resolve pass makes
 * of it, with the CPU twin of that resolve (for tests and dumps). */
#ifndef LEAP_SEGMENTS_H
#define LEAP_SEGMENTS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct leap_event {
    float t;
    uint32_t order;  /* entry or exit number of the box */
    uint32_t cls;    /* class after this event: the box's class (entry) or parent's (exit) */
} leap_event;

typedef struct leap_segment {
    float t0, t1;
    uint32_t cls;
} leap_segment;

/* Sorts events by (t, order) and walks them: after all events at one t are applied in order,
 * the current class is that of the region that follows. Emits a segment for each maximal run
 * of one class between the first and the last event t, zero-length runs dropped, class before
 * the first event = `outside`. Returns the number of segments; writes at most cap of them
 * (a return value > cap means overflow). */
size_t leap_resolve_events(leap_event *events, size_t count, uint32_t outside, leap_segment *out,
                           size_t cap);

#ifdef __cplusplus
}
#endif
#endif
