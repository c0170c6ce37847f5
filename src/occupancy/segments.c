/* The CPU twin of the GPU resolve: ray events to segments (see include/leap/segments.h). */
#include "leap/segments.h"

#include <stdlib.h>

static int event_before(const leap_event *a, const leap_event *b)
{
    if (a->t != b->t) return a->t < b->t;
    if (a->order != b->order) return a->order < b->order;
    return a->cls < b->cls;
}

static int event_cmp(const void *pa, const void *pb)
{
    const leap_event *a = pa, *b = pb;
    return event_before(a, b) ? -1 : (event_before(b, a) ? 1 : 0);
}

size_t leap_resolve_events(leap_event *events, size_t count, uint32_t outside, leap_segment *out,
                           size_t cap)
{
    /* events with a NaN t carry no position: moved to the end and ignored */
    size_t n = 0;
    for (size_t i = 0; i < count; ++i)
        if (events[i].t == events[i].t) {
            leap_event e = events[i];
            events[i] = events[n];
            events[n++] = e;
        }
    if (n <= 32) {
        for (size_t i = 1; i < n; ++i) {
            leap_event e = events[i];
            size_t j = i;
            while (j > 0 && event_before(&e, &events[j - 1])) {
                events[j] = events[j - 1];
                --j;
            }
            events[j] = e;
        }
    } else {
        qsort(events, n, sizeof *events, event_cmp);
    }

    size_t segs = 0;
    uint32_t cls = outside;
    float start = 0.0f;
    size_t i = 0;
    int first = 1;
    while (i < n) {
        const float t = events[i].t;
        uint32_t next = cls;
        for (; i < n && events[i].t == t; ++i) next = events[i].cls;
        if (first) {
            first = 0;
        } else if (next != cls || i == n) {
            /* the run [start, t) of class cls ends here (t > start: groups have distinct t) */
            if (segs < cap) {
                out[segs].t0 = start;
                out[segs].t1 = t;
                out[segs].cls = cls;
            }
            ++segs;
        } else {
            continue; /* no class change: the run goes on */
        }
        cls = next;
        start = t;
    }
    return segs;
}
