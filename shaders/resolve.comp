#version 450
#extension GL_GOOGLE_include_directive : require
#define LEAP_GLSL
#include "shared.h"
#include "bindings.glsl"

// Turns a pixel's ray events into its list of segments to march. Events are sorted by
// (t, order); after all events at one t are applied in order, the class of the last one is
// the class of the region that follows. A boundary is emitted only where the class changes,
// which realises the merge and delete rules (same-class duplicates, exit-then-entry into the
// same class, zero-length grazing hits). The CPU twin is leap_resolve_events.
layout(local_size_x = LEAP_COMPOSITE_GROUP, local_size_y = LEAP_COMPOSITE_GROUP) in;

bool marched(uint cls) { return cls != LEAP_CLASS_EMPTY; }

void main()
{
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.image.x || pix.y >= frame.image.y) return;
    uint pixel = pix.y * frame.image.x + pix.x;
    uint total = event_counts[pixel];
    uint flags = total > frame.lists.x ? LEAP_PIXEL_OVERFLOW : 0u;
    uint n = min(total, frame.lists.x);
    if (total == 0u) { // most pixels of a sparse scene: nothing to sort or walk
        pixel_lists[pixel] = uvec4(0u);
        return;
    }

    // Sorted insertion into a fixed set of slots indexed only by constants (the loops over
    // slots unroll), so the arrays live in registers: lavapipe runs dynamically indexed
    // arrays through memory, lane by lane. Empty slots hold t = +inf, which sorts last.
    float ts[LEAP_PIXEL_EVENTS];
    uint keys[LEAP_PIXEL_EVENTS];
    for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
        ts[s] = 1.0 / 0.0;
        keys[s] = 0xffffffffu;
    }
    uint base = pixel * uint(LEAP_PIXEL_EVENTS);
    for (uint e = 0u; e < n; ++e) {
        float t = event_t[base + e];
        uint key = event_key[base + e];
        for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
            bool before = t < ts[s] || (t == ts[s] && key < keys[s]);
            float ts_s = ts[s];
            uint keys_s = keys[s];
            ts[s] = before ? t : ts_s;
            keys[s] = before ? key : keys_s;
            t = before ? ts_s : t;
            key = before ? keys_s : key;
        }
    }

    uint seg_base = pixel * frame.lists.y;
    uint count = 0u, unknown_mask = 0u;
    uint cls = LEAP_CLASS_EMPTY; // outside every box
    float start = 0.0;
    for (int s = 0; s < LEAP_PIXEL_EVENTS; ++s) {
        if (uint(s) >= n) break;
        // The last event of a group of equal t gives the class of what follows.
        bool last = uint(s) + 1u >= n || ts[min(s + 1, LEAP_PIXEL_EVENTS - 1)] != ts[s];
        uint next = keys[s] & 3u;
        if (uint(s) < n && flags == 0u && last && next != cls) {
            if (marched(cls)) {
                if (count == frame.lists.y) {
                    flags |= LEAP_PIXEL_OVERFLOW;
                } else {
                    segments[seg_base + count] = vec2(start, ts[s]);
                    if (cls == LEAP_CLASS_UNKNOWN) unknown_mask |= 1u << count;
                    ++count;
                }
            }
            cls = next;
            start = ts[s];
        }
    }
    pixel_lists[pixel] = uvec4(count | flags, total, unknown_mask, 0u);
}
